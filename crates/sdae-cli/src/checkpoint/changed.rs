//! What differs between the run that saved a checkpoint and the run asked to resume from it,
//! named as the command line sets it, with the saved and the asked value: `--randomizations
//! (saved 32, asked 8)`.

use sdae_study::convergence::ConvergenceSettings;
use sdae_study::scene::{Scene, escaped};

/// A setting as a refusal to resume names it: its flag (or name), its saved value and the
/// asked one.
pub(crate) type Setting = (&'static str, String, String);

/// The first of `settings` whose saved and asked values differ, named with both.
pub(crate) fn first_changed(settings: &[Setting]) -> Option<String> {
    settings
        .iter()
        .find(|(_, saved, asked)| saved != asked)
        .map(|(name, saved, asked)| format!("{name} (saved {saved}, asked {asked})"))
}

/// A switch as a refusal names its value: `with --qmc` or `without --qmc`.
pub(crate) fn switch(flag: &str, on: bool) -> String {
    if on {
        format!("with {flag}")
    } else {
        format!("without {flag}")
    }
}

/// How a refusal names a scene that differs from the saved one: by both names, or, for a scene
/// of the same name, as changed since (its file edited).
pub(crate) fn scene_change(saved: &Scene, asked: &Scene) -> String {
    if saved.name == asked.name {
        format!("scene: {} changed since it was saved", escaped(&asked.name))
    } else {
        format!(
            "scene (saved {}, asked {})",
            escaped(&saved.name),
            escaped(&asked.name)
        )
    }
}

/// How a refusal names a shard (i, n) that differs from the saved one: `--shard (saved 1/2,
/// asked 0/2)`, a run that is not sharded as `none`.
pub(crate) fn shard_change(saved: Option<(u64, u64)>, asked: Option<(u64, u64)>) -> String {
    let shown = |s: Option<(u64, u64)>| s.map_or("none".into(), |(i, n)| format!("{i}/{n}"));
    format!("--shard (saved {}, asked {})", shown(saved), shown(asked))
}

/// What of the settings `saved` differs from `asked` (the thread count aside), named by the
/// first differing one the command line sets; `None` when only other settings differ.
pub(crate) fn convergence_change(
    saved: &ConvergenceSettings, asked: &ConvergenceSettings,
) -> Option<String> {
    let each = |name: &'static str, value: fn(&ConvergenceSettings) -> String| -> Setting {
        (name, value(saved), value(asked))
    };
    first_changed(&[
        each("--qmc", |s| switch("--qmc", s.randomizations.is_some())),
        each("--randomizations", |s| {
            s.randomizations.map_or("none".into(), |r| r.to_string())
        }),
        each("--paths", |s| s.paths.to_string()),
        each("--levels", |s| format!("{}..{}", s.coarsest, s.finest)),
        each("--ref-level", |s| {
            s.reference.map_or("none".into(), |r| r.to_string())
        }),
        each("--t-end", |s| format!("{:?}", s.t_end)),
        each("--seed", |s| s.seed.to_string()),
        each("--p", |s| format!("{:?}", s.p)),
        each("--schemes", |s| {
            let names: Vec<&str> = s.schemes.iter().map(|k| k.name()).collect();
            names.join(",")
        }),
        each("--reference-scheme", |s| s.reference_scheme.name().into()),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_changed_setting_is_named_with_both_values() {
        let scene = Scene::built_in("pendulum").unwrap();
        let saved = ConvergenceSettings::for_scene(&scene);
        assert_eq!(convergence_change(&saved, &saved), None);
        let asked = ConvergenceSettings {
            randomizations: Some(8),
            ..saved.clone()
        };
        assert_eq!(
            convergence_change(&saved, &asked).as_deref(),
            Some("--qmc (saved without --qmc, asked with --qmc)")
        );
        let resaved = ConvergenceSettings {
            randomizations: Some(16),
            ..saved.clone()
        };
        assert_eq!(
            convergence_change(&resaved, &asked).as_deref(),
            Some("--randomizations (saved 16, asked 8)")
        );
    }
}
