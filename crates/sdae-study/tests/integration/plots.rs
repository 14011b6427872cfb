//! Every SVG the studies write, read back as text: no two lines of a legend share a (colour,
//! marker) pair, the eleven built-in schemes differ in marker alone (grey print), every legend
//! marker is drawn in the panels, and the legend's box lies outside every panel's plotting
//! area. Convergence, stability, equipartition and weak plots with 11 schemes and with 2; MLMC
//! and trace plots as the studies draw them.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use sdae_study::convergence::{
    ConvergenceReport, ConvergenceSettings, build_report, run_convergence,
};
use sdae_study::equipartition::{self, EquipartitionScene};
use sdae_study::integrator::SchemeKind;
use sdae_study::mlmc::study::{MlmcSettings, run_mlmc};
use sdae_study::parallel::Control;
use sdae_study::scene::Scene;
use sdae_study::stability::{self, StabilityReport, StabilityScene};
use sdae_study::weak::{build_weak_report, report as weak_report, weak_settings};
use sdae_study::{plots, trace};

/// An element of an SVG file: its tag, attributes and text.
#[derive(Debug, Clone)]
struct Element {
    tag: String,
    attrs: BTreeMap<String, String>,
    text: String,
}

impl Element {
    fn num(&self, key: &str) -> f64 {
        self.attrs[key].parse().unwrap()
    }
    fn attr(&self, key: &str) -> &str {
        self.attrs.get(key).map_or("", String::as_str)
    }
    fn points(&self) -> Vec<(f64, f64)> {
        self.attr("points")
            .split_whitespace()
            .map(|p| {
                let (x, y) = p.split_once(',').unwrap();
                (x.parse().unwrap(), y.parse().unwrap())
            })
            .collect()
    }
}

/// Reads the elements of an SVG text (one level deep, as plotters writes it).
fn parse(svg: &str) -> Vec<Element> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(start) = rest.find('<') {
        rest = &rest[start + 1..];
        let end = rest.find('>').unwrap();
        let tag_text = &rest[..end];
        rest = &rest[end + 1..];
        if tag_text.starts_with('/') || tag_text.starts_with('?') || tag_text.starts_with('!') {
            continue;
        }
        let tag: String = tag_text
            .chars()
            .take_while(|c| c.is_alphanumeric())
            .collect();
        let mut attrs = BTreeMap::new();
        let mut a = &tag_text[tag.len()..];
        while let Some(eq) = a.find("=\"") {
            let key = a[..eq].trim().to_string();
            let value_end = a[eq + 2..].find('"').unwrap();
            attrs.insert(key, a[eq + 2..eq + 2 + value_end].to_string());
            a = &a[eq + 3 + value_end..];
        }
        let text = if tag == "text" {
            let close = rest.find("</text>").unwrap();
            rest[..close].trim().to_string()
        } else {
            String::new()
        };
        out.push(Element { tag, attrs, text });
    }
    out
}

/// A box (x0, y0, x1, y1).
type Bounds = (f64, f64, f64, f64);

fn rect_bounds(e: &Element) -> Bounds {
    let (x, y) = (e.num("x"), e.num("y"));
    (x, y, x + e.num("width"), y + e.num("height"))
}

fn overlap(a: Bounds, b: Bounds) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

fn inside(p: (f64, f64), b: Bounds) -> bool {
    (b.0..=b.2).contains(&p.0) && (b.1..=b.3).contains(&p.1)
}

/// A marker: its centre and what tells it apart, (shape, colour) (shape: the tag, filled or
/// not, and the corners about the centre).
fn marker(e: &Element) -> Option<((f64, f64), String, String)> {
    let filled = e.attr("fill") != "none";
    let colour = if filled {
        e.attr("fill")
    } else {
        e.attr("stroke")
    }
    .to_uppercase();
    match e.tag.as_str() {
        "circle" => Some((
            (e.num("cx"), e.num("cy")),
            format!("circle r{} filled {filled}", e.attr("r")),
            colour,
        )),
        "polygon" | "polyline" => {
            let p = e.points();
            let closed = p.len() > 3 && p.first() == p.last();
            if e.tag == "polyline" && !closed {
                return None;
            }
            let (x0, x1) = p
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), q| (a.min(q.0), b.max(q.0)));
            let (y0, y1) = p
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), q| (a.min(q.1), b.max(q.1)));
            if x1 - x0 > 16.0 || y1 - y0 > 16.0 {
                return None;
            }
            let c = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
            let corners: Vec<String> = p
                .iter()
                .map(|q| format!("{},{}", q.0 - c.0, q.1 - c.1))
                .collect();
            Some((c, format!("{} {}", e.tag, corners.join(" ")), colour))
        }
        _ => None,
    }
}

/// What a plot's check found: the legend's labels with their (shape, colour).
struct Legend {
    entries: Vec<(String, String, String)>,
}

/// Reads `path` and checks its frames, legend and markers; gives back the legend.
fn check(path: &Path) -> Legend {
    let svg = std::fs::read_to_string(path).unwrap();
    let elements = parse(&svg);
    let name = path.display();
    let frame = |hex: &str| {
        elements
            .iter()
            .filter(|e| e.tag == "rect" && e.attr("fill") == "none")
            .filter(|e| e.attr("stroke").eq_ignore_ascii_case(hex))
            .map(rect_bounds)
            .collect::<Vec<_>>()
    };
    let panels = frame("#4D4D4D");
    assert!(!panels.is_empty(), "{name}: no panel");
    let legends = frame("#AAAAAA");
    let Some(&legend) = legends.first() else {
        return Legend {
            entries: Vec::new(),
        };
    };
    assert_eq!(legends.len(), 1, "{name}: one legend");
    for p in &panels {
        assert!(
            !overlap(legend, *p),
            "{name}: legend {legend:?} over panel {p:?}"
        );
    }
    let markers: Vec<_> = elements.iter().filter_map(marker).collect();
    let labels: Vec<&Element> = elements
        .iter()
        .filter(|e| e.tag == "text" && e.attr("fill").eq_ignore_ascii_case("#000000"))
        .filter(|e| inside((e.num("x"), e.num("y")), legend))
        .collect();
    let mut entries = Vec::new();
    for label in labels {
        let (x, y) = (label.num("x"), label.num("y"));
        // The label's drawn width, at most 0.6 em per character, stays in the box.
        let width = 0.6 * label.num("font-size") * label.text.chars().count() as f64;
        assert!(
            x + width <= legend.2,
            "{name}: {} sticks out of the legend",
            label.text
        );
        let own: Vec<_> = markers
            .iter()
            .filter(|(c, ..)| (c.1 - y).abs() <= 2.0 && c.0 < x && c.0 > x - 40.0)
            .collect();
        assert_eq!(own.len(), 1, "{name}: one marker for {}", label.text);
        let (_, shape, colour) = own[0].clone();
        let drawn = markers
            .iter()
            .filter(|(c, s, k)| {
                *s == shape && *k == colour && panels.iter().any(|p| inside(*c, *p))
            })
            .count();
        assert!(
            drawn > 0,
            "{name}: the marker of {} is in no panel",
            label.text
        );
        entries.push((label.text.clone(), shape, colour));
    }
    for (i, a) in entries.iter().enumerate() {
        for b in &entries[i + 1..] {
            assert!(
                (&a.1, &a.2) != (&b.1, &b.2),
                "{name}: {} and {} look alike",
                a.0,
                b.0
            );
        }
    }
    Legend { entries }
}

/// Checks `path` and that its legend has the `schemes` (and perhaps more lines), the built-in
/// ones each with a colour and a marker shape of its own.
fn check_schemes(path: &Path, schemes: &[&str]) {
    let legend = check(path);
    let found: Vec<&(String, String, String)> = schemes
        .iter()
        .map(|s| {
            let e = legend.entries.iter().find(|e| e.0 == *s);
            e.unwrap_or_else(|| panic!("{}: no legend entry {s}", path.display()))
        })
        .collect();
    for (i, a) in found.iter().enumerate() {
        for b in &found[i + 1..] {
            assert_ne!(
                a.1,
                b.1,
                "{}: {} and {} share a marker",
                path.display(),
                a.0,
                b.0
            );
            assert_ne!(
                a.2,
                b.2,
                "{}: {} and {} share a colour",
                path.display(),
                a.0,
                b.0
            );
        }
    }
}

fn dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sdae-plots-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn names(report: &ConvergenceReport) -> Vec<&str> {
    report.schemes.iter().map(|s| s.name.as_str()).collect()
}

fn pendulum_report() -> ConvergenceReport {
    let scene = Scene::built_in("pendulum").unwrap();
    let settings = ConvergenceSettings {
        paths: 64,
        coarsest: 3,
        finest: 5,
        reference: Some(8),
        threads: 2,
        ..ConvergenceSettings::for_scene(&scene)
    };
    let report =
        build_report(run_convergence(&scene, &settings, (0, 1), Control::default()).unwrap());
    assert_eq!(report.schemes.len(), SchemeKind::ALL.len());
    report
}

fn two(mut report: ConvergenceReport) -> ConvergenceReport {
    report
        .schemes
        .retain(|s| s.name == "half-explicit-practical" || s.name == "g-baoab");
    report
}

#[test]
fn convergence_and_stability_plots_tell_11_and_2_schemes_apart_outside_the_panels() {
    let all = pendulum_report();
    let some = two(all.clone());
    for (report, tag) in [(&all, "11"), (&some, "2")] {
        let out = dir(&format!("convergence-{tag}"));
        plots::write_plots(report, &out).unwrap();
        check_schemes(&out.join("error_vs_h.svg"), &names(report));
        check_schemes(&out.join("error_vs_time.svg"), &names(report));
        let stability = StabilityReport {
            scenes: ["a", "b", "c", "d"]
                .map(|case| StabilityScene {
                    case: case.into(),
                    report: report.clone(),
                })
                .into(),
        };
        let path = out.join("stability.svg");
        stability::plot(&stability, &path).unwrap();
        check_schemes(&path, &names(report));
    }
    // The run time is the median of the blocks' timings, with their range.
    let level = &all.schemes[0].levels[0];
    assert!(level.seconds.min <= level.seconds.median && level.seconds.median <= level.seconds.max);
    assert!(level.seconds.min > 0.0);
}

#[test]
fn weak_plots_tell_schemes_and_their_extrapolations_apart() {
    let scene = Scene::built_in("pendulum").unwrap();
    let mut settings = weak_settings(&scene, true).unwrap();
    settings.paths = 200;
    settings.threads = 2;
    settings.schemes = SchemeKind::ALL.to_vec();
    let run = run_convergence(&scene, &settings, (0, 1), Control::default()).unwrap();
    let mut report = build_weak_report(run).unwrap();
    let all: Vec<String> = SchemeKind::ALL
        .iter()
        .map(|k| k.name().to_string())
        .collect();
    for keep in [all.clone(), vec![all[0].clone(), all[5].clone()]] {
        for o in &mut report.observables {
            o.schemes
                .retain(|row| keep.iter().any(|k| row.name.starts_with(k.as_str())));
        }
        let out = dir(&format!("weak-{}", keep.len()));
        weak_report::write_report(&report, &out).unwrap();
        let keep: Vec<&str> = keep.iter().map(String::as_str).collect();
        check_schemes(&out.join("weak_error_vs_h.svg"), &keep);
        check_schemes(&out.join("weak_error_vs_time.svg"), &keep);
    }
}

/// The equipartition study of the Gibbs pendulum, quick.
fn gibbs() -> EquipartitionScene {
    let scene = Scene::built_in("gibbs-pendulum").unwrap();
    let runs: Vec<_> = equipartition::variants(&scene, true)
        .unwrap()
        .into_iter()
        .map(|v| {
            let settings = ConvergenceSettings {
                threads: 2,
                ..v.settings
            };
            run_convergence(&v.scene, &settings, (0, 1), Control::default()).unwrap()
        })
        .collect();
    equipartition::collect(&runs).unwrap()
}

#[test]
fn equipartition_and_bias_plots_tell_every_variant_apart() {
    let all = gibbs();
    let drawn =
        |r: &equipartition::EquipartitionRow| r.temperature_ratio.is_some_and(|t| t.estimate > 0.0);
    let first = all.rows.iter().find(|r| drawn(r)).unwrap().scheme.clone();
    let last = all.rows.iter().rfind(|r| drawn(r)).unwrap().scheme.clone();
    let mut some = all.clone();
    some.rows.retain(|r| r.scheme == first || r.scheme == last);
    for study in some.configurational.iter_mut().chain(&mut some.kinetic) {
        study.schemes.truncate(2);
    }
    for (scene, tag) in [(all, "all"), (some, "2")] {
        let out = dir(&format!("equipartition-{tag}"));
        equipartition::write_report(std::slice::from_ref(&scene), &out).unwrap();
        // Every variant with a ratio to draw is in the legend.
        let mut rows: Vec<&str> = scene
            .rows
            .iter()
            .filter(|r| drawn(r))
            .map(|r| r.scheme.as_str())
            .collect();
        rows.dedup();
        assert!(rows.len() >= 2, "{tag}: {rows:?}");
        let legend = check(&out.join("equipartition.svg"));
        assert_eq!(legend.entries.len(), rows.len(), "{tag}");
        assert!(!check(&out.join("bias.svg")).entries.is_empty());
    }
}

#[test]
fn mlmc_and_trace_plots_keep_their_legends_outside_the_panels() {
    let scene = Scene::built_in("pendulum").unwrap();
    let mut settings = MlmcSettings::for_scene(&scene).quick();
    settings.threads = 2;
    let control = sdae_mlmc::RunControl::new(2).unwrap();
    let report = run_mlmc(&scene, &settings, &control).unwrap();
    let out = dir("mlmc");
    sdae_study::mlmc::plots::write_plots(&report, &out).unwrap();
    for file in ["levels.svg", "samples.svg", "cost.svg"] {
        assert!(check(&out.join(file)).entries.len() >= 2, "{file}");
    }
    for name in ["chain-molecule", "pendulum"] {
        let scene = Scene::built_in(name).unwrap();
        let t = trace::trace(&scene, 256, 7).unwrap();
        let path = out.join(format!("{name}.svg"));
        trace::plot(&t, name, &path).unwrap();
        let legend = check(&path);
        assert_eq!(
            legend.entries.len(),
            if name == "pendulum" { 0 } else { 6 },
            "{name}"
        );
    }
}
