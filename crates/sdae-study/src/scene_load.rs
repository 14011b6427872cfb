//! Reading a scene, from TOML text, a file or the built-in ones, and checking it: ranges and
//! consistency of its values, the observables of its `[weak]` table, and the settings each of
//! its study tables gives as the studies will run them. (The checks of the study tables use the
//! studies' settings, so they sit here, above the studies, not in [`crate::scene`].)

use sdae_splitting::SplittingConfig;
use sdae_systems::MAX_PARTICLES;

use crate::catalog::BUILT_IN;
use crate::convergence::ConvergenceSettings;
use crate::equipartition;
use crate::error::StudyError;
use crate::mlmc::MlmcSettings;
use crate::mlmc::settings::study_error;

use crate::scene::{
    InitialSpec, Output, Scene, SceneSystem, SchemeSpec, StudyDefaults, SystemSpec, SystemVisitor,
    WeakSpec,
};
use crate::stability::stability_settings;
use crate::weak::weak_table_settings;

impl StudyError {
    /// The error with the scene file it came from: an invalid scene's message names `file`
    /// on its first line, before the colon that ends the line where one does, so that an
    /// expression's text and the caret line under it, on the lines below, stay aligned; any
    /// other error as it is.
    pub fn in_scene_file(self, file: &str) -> StudyError {
        let StudyError::Invalid { scene, message } = self else {
            return self;
        };
        let named = |line: &str| match line.strip_suffix(':') {
            Some(head) => format!("{head} (scene file {file}):"),
            None => format!("{line} (scene file {file})"),
        };
        let message = match message.split_once('\n') {
            Some((first, rest)) => format!("{}\n{rest}", named(first)),
            None => named(&message),
        };
        StudyError::Invalid { scene, message }
    }
}

impl Scene {
    /// Reads a scene from TOML text.
    pub fn from_toml(text: &str) -> Result<Self, StudyError> {
        Self::parse(text, "<inline>")
    }

    fn parse(text: &str, file: &str) -> Result<Self, StudyError> {
        Self::checked(toml::from_str(text).map_err(|e| e.to_string()), file)
    }

    /// Reads a scene from JSON text with the keys of a scene file (a table of another
    /// language, such as a Python dict, written as JSON).
    pub fn from_json(text: &str) -> Result<Self, StudyError> {
        Self::checked(
            serde_json::from_str(text).map_err(|e| e.to_string()),
            "<inline>",
        )
    }

    /// The scene read from `file` (or why it could not be read), once its checks pass; a
    /// refusal names the file (a scene given as text, `"<inline>"`, has none to name).
    fn checked(read: Result<Scene, String>, file: &str) -> Result<Self, StudyError> {
        let scene = read.map_err(|message| StudyError::Format {
            file: file.to_string(),
            message,
        })?;
        scene.validate().map_err(|e| match file {
            "<inline>" => e,
            file => e.in_scene_file(file),
        })?;
        Ok(scene)
    }

    /// Reads a scene file.
    pub fn from_file(path: &std::path::Path) -> Result<Self, StudyError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| StudyError::Io {
            file: file.clone(),
            message: e.to_string(),
        })?;
        Self::parse(&text, &file)
    }

    /// A built-in scene by name.
    pub fn built_in(name: &str) -> Result<Self, StudyError> {
        let (_, text) = BUILT_IN
            .iter()
            .find(|(n, _)| *n == name)
            .ok_or_else(|| StudyError::Unknown(crate::scene::escaped(name)))?;
        Self::parse(text, &format!("scenes/{name}.toml"))
    }

    /// The scene of a system built in code: its name, T and outputs, the practical C_eta of
    /// the half-explicit scheme, the study defaults (`paths`, `levels`, `reference`) left to the
    /// studies' settings. Checked like a scene file.
    pub fn custom(
        name: &str, t_end: f64, outputs: Vec<Output>, practical_c_eta: f64,
    ) -> Result<Self, StudyError> {
        let scene = Scene {
            name: name.into(),
            description: format!("custom system {name}"),
            t_end,
            outputs,
            system: SystemSpec::Custom(name.into()),
            initial: InitialSpec::default(),
            scheme: SchemeSpec {
                practical_c_eta,
                ..SchemeSpec::default()
            },
            study: StudyDefaults::default(),
            stability: None,
            equipartition: None,
            mlmc: None,
            weak: None,
        };
        scene.validate()?;
        Ok(scene)
    }

    /// Checks what the types cannot: ranges and consistency.
    fn validate(&self) -> Result<(), StudyError> {
        self.validate_system()?;
        self.validate_scheme()?;
        self.validate_tables()?;
        if let Some(weak) = &self.weak {
            self.validate_weak(weak)?;
        }
        self.validate_studies()
    }

    /// The name, T, the initial state's form and the system's size.
    fn validate_system(&self) -> Result<(), StudyError> {
        if self.name.is_empty()
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            let name = crate::scene::escaped(&self.name);
            return Err(StudyError::Invalid {
                message: format!(
                    "name = '{name}': use letters, digits, '-' and '_' (it names the report's \
                     files)"
                ),
                scene: name,
            });
        }
        if !(self.t_end.is_finite() && self.t_end > 0.0) {
            return Err(self.invalid(format!("T = {}: must be finite and > 0", self.t_end)));
        }
        self.check_expressions()?;
        if self.initial.shape.is_some() && self.initial.position.is_some() {
            return Err(self.invalid("initial: give either shape or position, not both"));
        }
        struct Chain;
        impl SystemVisitor for Chain {
            type Output = Option<(&'static str, usize)>;
            fn visit<K: SceneSystem>(self, kind: &K) -> Self::Output {
                kind.chain()
            }
        }
        let chain = self.system.visit(Chain).ok().flatten();
        if self.initial.shape.is_some() && chain.is_none() {
            return Err(self
                .invalid("initial.shape applies to chains of beads (chain-molecule, fiber) only"));
        }
        if let Some((key, count)) = chain
            && count > MAX_PARTICLES
        {
            return Err(self.invalid(format!(
                "system.{key} = {count}: must be at most {MAX_PARTICLES} (the largest system built)"
            )));
        }
        Ok(())
    }

    /// The outputs and the scheme's constants.
    fn validate_scheme(&self) -> Result<(), StudyError> {
        if self.outputs.is_empty() {
            return Err(self.invalid("outputs is empty: name at least one output"));
        }
        let c_eta = self.scheme.practical_c_eta;
        if !(c_eta.is_finite() && c_eta > 0.0) {
            return Err(self.invalid(format!(
                "scheme.practical_c_eta = {c_eta}: must be finite and > 0"
            )));
        }
        let local = self.scheme.local_c_eta;
        if !(local.is_finite() && local > 0.0) {
            return Err(self.invalid(format!(
                "scheme.local_c_eta = {local}: must be finite and > 0"
            )));
        }
        if let Some(c) = self.scheme.c_kappa
            && (c.is_nan() || c <= 0.0)
        {
            return Err(self.invalid(format!("scheme.c_kappa = {c}: must be > 0")));
        }
        let splitting = SplittingConfig::g_baoab()
            .with_substeps(self.scheme.geodesic_substeps)
            .and_then(|c| c.with_tolerance(self.scheme.projection_tolerance));
        if let Err(e) = splitting {
            return Err(self.invalid(format!("scheme: {e}")));
        }
        Ok(())
    }

    /// The ranges of the [study], [stability] and [equipartition] tables.
    fn validate_tables(&self) -> Result<(), StudyError> {
        if let Some([a, b]) = self.study.levels
            && a > b
        {
            return Err(self.invalid(format!("study.levels = [{a}, {b}] is empty")));
        }
        if let Some(st) = &self.stability {
            let [a, b] = st.levels;
            if a > b {
                return Err(self.invalid(format!("stability.levels = [{a}, {b}] is empty")));
            }
            for (name, x) in [
                ("drift_tolerance", st.drift_tolerance),
                ("blow_up", st.blow_up),
            ] {
                if x.is_nan() || x <= 0.0 {
                    return Err(self.invalid(format!("stability.{name} = {x}: must be > 0")));
                }
            }
        }
        if let Some(eq) = &self.equipartition {
            if !self.wants(Output::KineticEnergy) {
                return Err(
                    self.invalid("an [equipartition] table needs \"kinetic-energy\" in outputs")
                );
            }
            let [a, b] = eq.levels;
            if a > b {
                return Err(self.invalid(format!("equipartition.levels = [{a}, {b}] is empty")));
            }
            if !(eq.burn_in >= 0.0 && eq.burn_in < eq.t_end) {
                return Err(self.invalid(format!(
                    "equipartition.burn_in = {}: must be in [0, equipartition.T = {})",
                    eq.burn_in, eq.t_end
                )));
            }
            if let Some(c) = eq.c_eta.iter().find(|c| !(c.is_finite() && **c > 0.0)) {
                return Err(self.invalid(format!(
                    "equipartition.c_eta contains {c}: each must be finite and > 0"
                )));
            }
            if let Some(name) = &eq.configurational {
                crate::observable::check_known(self, name)?;
            }
        }
        Ok(())
    }

    /// Checks the study settings each table of the scene gives ([study], [stability],
    /// [equipartition], [weak] with and without `--quick`, [mlmc] with and without `--quick`)
    /// as the studies will run them (before the command line changes them), naming a bad value
    /// by its key in that table.
    fn validate_studies(&self) -> Result<(), StudyError> {
        let tables = [
            ("study", Some(ConvergenceSettings::for_scene(self))),
            ("stability", stability_settings(self, false)),
            (
                "equipartition",
                equipartition::variants(self, false)
                    .and_then(|v| v.into_iter().next())
                    .map(|v| v.settings),
            ),
        ];
        let weak = [false, true].map(|quick| ("weak", weak_table_settings(self, quick)));
        for (table, settings) in tables.into_iter().chain(weak) {
            if let Some(Err(StudyError::Setting { key, value, rule })) =
                settings.map(|s| s.validate())
            {
                let key = key_in_table(table, key);
                return Err(self.invalid(format!("{key} = {value}: {rule}")));
            }
        }
        if self.mlmc.is_some() {
            let settings = MlmcSettings::for_scene(self);
            for settings in [settings.clone(), settings.quick()] {
                settings.validate().map_err(|e| match study_error(&e) {
                    Some(e) => e.clone(),
                    None => self.invalid(e.to_string()),
                })?;
            }
        }
        Ok(())
    }

    /// Checks a `[weak]` table: known observables whose outputs the scene computes, exact
    /// values finite and of named observables, non-empty levels.
    fn validate_weak(&self, weak: &WeakSpec) -> Result<(), StudyError> {
        if weak.observables.is_empty() {
            return Err(self.invalid("weak.observables is empty: name at least one observable"));
        }
        for name in &weak.observables {
            crate::observable::check(self, name)?;
        }
        for (name, value) in &weak.exact {
            if !weak.observables.contains(name) {
                return Err(self.invalid(format!(
                    "weak.exact.{name}: not one of weak.observables ({})",
                    weak.observables.join(", ")
                )));
            }
            if !value.is_finite() {
                return Err(self.invalid(format!("weak.exact.{name} = {value}: must be finite")));
            }
        }
        if let Some([a, b]) = weak.levels
            && a > b
        {
            return Err(self.invalid(format!("weak.levels = [{a}, {b}] is empty")));
        }
        Ok(())
    }
}

/// The key in the scene file's table `table` (`study`, `stability`, `equipartition`, `weak`)
/// of a study setting that [`ConvergenceSettings::validate`] names by its `[study]` key
/// (`study.paths`) or field (`T`): `weak.paths` for the weak study's paths.
pub fn key_in_table(table: &str, key: &'static str) -> &'static str {
    match (table, key) {
        ("weak", "study.paths") => "weak.paths",
        ("weak", "study.levels") => "weak.levels",
        ("weak", "study.reference") => "weak.reference",
        ("stability", "study.paths") => "stability.paths",
        ("stability", "study.levels") => "stability.levels",
        ("stability", "study.reference") => "stability.reference",
        ("stability", "limits.drift_tolerance") => "stability.drift_tolerance",
        ("stability", "limits.blow_up") => "stability.blow_up",
        ("equipartition", "study.paths") => "equipartition.paths",
        ("equipartition", "study.levels") => "equipartition.levels",
        ("equipartition", "T") => "equipartition.T",
        (_, key) => key,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PENDULUM: &str = include_str!("../scenes/pendulum.toml");

    /// The message of the error reading the pendulum scene with `from` replaced by `to`.
    fn refused(from: &str, to: &str) -> String {
        assert!(PENDULUM.contains(from), "'{from}' not in the scene");
        Scene::from_toml(&PENDULUM.replace(from, to))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn weak_table_settings_are_named_by_their_own_key() {
        // The [study] table's paths stay 10000: the [weak] table's are named.
        let message = refused("paths = 40000", "paths = 0");
        assert!(
            message.contains("weak.paths = 0: must be >= 2"),
            "{message}"
        );
        assert!(!message.contains("study.paths"), "{message}");
        let message = refused(
            "levels = [2, 7]\nreference = 11",
            "levels = [2, 7]\nreference = 40",
        );
        assert!(message.contains("weak.reference = 40"), "{message}");
        let message = refused("levels = [2, 7]\nreference = 11", "levels = [2, 30]");
        assert!(message.contains("weak.levels = 2..30"), "{message}");
        let message = refused("levels = [2, 7]\nreference = 11", "levels = [9, 10]");
        assert!(message.contains("weak.levels = 9..10"), "{message}");
    }

    #[test]
    fn mlmc_table_settings_are_named_by_their_own_key() {
        let with = |table: &str| {
            Scene::from_toml(&format!("{PENDULUM}\n[mlmc]\n{table}\n"))
                .unwrap_err()
                .to_string()
        };
        let message = with("coarsest = 0");
        assert!(message.contains("mlmc.coarsest = 0"), "{message}");
        let message = with("test_samples = 1000000000000");
        assert!(
            message.contains("mlmc.test_samples = 1000000000000") && message.contains("available"),
            "{message}"
        );
        let message = with("coarsest = 4294967295\nmax_level = 2");
        assert!(message.contains("mlmc.coarsest = 4294967295"), "{message}");
        let message = with("coarsest = 20\nmax_level = 12");
        assert!(message.contains("mlmc.max_level = 12"), "{message}");
        let message = with("eps = [1e-2, 1e-300]");
        assert!(message.contains("mlmc.eps = 1e-300"), "{message}");
        let message = with("eps = []");
        assert!(message.contains("mlmc.eps = []"), "{message}");
        assert!(Scene::from_toml(&format!("{PENDULUM}\n[mlmc]\ncoarsest = 3\n")).is_ok());
    }
}
