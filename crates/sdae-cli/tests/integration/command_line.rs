//! The study binary on good and bad command lines: exit codes (0 ran, 1 ran but nothing to
//! compare, 2 usage), and messages that name the option and the nearest valid name.

use crate::cli;

use std::path::{Path, PathBuf};

use cli::{ran, study, text, usage_error};

/// The built-in pendulum scene under another name (so that its results get their own folder).
fn scene() -> String {
    include_str!("../../../sdae-study/scenes/pendulum.toml")
        .replace("name = \"pendulum\"", "name = \"test\"")
}

/// Runs the study, requires exit code 1 (it ran, nothing to compare) and returns stderr.
fn ran_but_failed(args: &[&str]) -> String {
    let out = study(args);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
    stderr
}

/// A fresh folder for one test.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sdae-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A fresh folder for one test and the scene file `text` written in it.
fn folder_with_scene(name: &str, text: &str) -> (PathBuf, PathBuf) {
    let dir = folder(name);
    let file = scene_file(&dir, text);
    (dir, file)
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Runs the study with `args` and `--out dir`, requires exit code 0 and returns stderr.
fn ran_into(dir: &Path, args: &[&str]) -> String {
    text(&ran(&[args, &["--out", path(dir)]].concat()).stderr)
}

#[test]
fn misspelled_subcommands_options_and_values_name_the_nearest_valid_one() {
    usage_error(&["stabilty", "--quick"], &["'stabilty'", "'stability'"]);
    usage_error(&["--path", "5"], &["'--path'", "--paths"]);
    usage_error(&["--scene", "pendulm"], &["'pendulm'", "'pendulum'"]);
    usage_error(&["--schemes", "euler"], &["'euler'", "'euler-maruyama'"]);
}

#[test]
fn options_a_subcommand_does_not_take_are_errors() {
    usage_error(&["stability", "--levels", "3..5"], &["'--levels'"]);
    usage_error(&["trace", "--paths", "5"], &["'--paths'"]);
    usage_error(&["merge"], &["DIR"]);
}

#[test]
fn values_are_checked_and_a_missing_value_is_named() {
    usage_error(&["--threads", "0"], &["--threads", "at least 1"]);
    usage_error(&["--paths"], &["--paths"]);
    usage_error(&["--paths", "--out", "x"], &["--paths"]);
    usage_error(&["--levels", "8..3"], &["--levels", "A..B"]);
    // --quick puts its reference above the levels given, and the levels are named.
    usage_error(&["--quick", "--levels", "3..70"], &["--levels 3..70"]);
    usage_error(&["--shard", "4/4"], &["--shard"]);
    // Settings the library checks are named by their flags.
    usage_error(&["--paths", "1", "--quick"], &["--paths 1: must be >= 2"]);
    usage_error(
        &["--shard", "auto", "--quick"],
        &["SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_COUNT"],
    );
}

#[test]
fn version_help_and_list_exit_0() {
    let out = study(&["--version"]);
    assert_eq!(out.status.code(), Some(0));
    assert!(text(&out.stdout).contains(env!("CARGO_PKG_VERSION")));
    let out = study(&["--help"]);
    assert_eq!(out.status.code(), Some(0));
    let help = text(&out.stdout);
    for word in [
        "stability",
        "equipartition",
        "merge",
        "trace",
        "--t-end",
        "--resume",
    ] {
        assert!(help.contains(word), "help lacks {word}:\n{help}");
    }
    let out = study(&["list"]);
    assert_eq!(out.status.code(), Some(0));
    assert!(text(&out.stdout).contains("stochastic-heun"));
}

#[test]
fn a_good_run_exits_0_and_t_end_has_its_old_spelling() {
    let dir = folder("good");
    let file = dir.join("scene.toml");
    std::fs::write(&file, scene()).unwrap();
    for t in ["--t-end", "--T"] {
        let args = ["--scene-file", path(&file), "--quick", "--paths", "4"];
        let stderr = ran_into(&dir, &[&args[..], &[t, "0.5", "--levels", "2..4"]].concat());
        assert!(stderr.contains("T = 0.5"), "{stderr}");
        let report = std::fs::read_to_string(dir.join("test").join("report.json")).unwrap();
        assert!(report.contains("\"T\": 0.5,"), "{report}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_study_with_nothing_to_compare_exits_1_naming_the_failures() {
    let dir = folder("uncompared");
    let file = dir.join("fast.toml");
    // |v|^2 overflows: the reference fails on its first step, on every path.
    let fast = scene().replace("velocity = [1.0, 0.0]", "velocity = [1e200, 0.0]");
    assert_ne!(fast, scene());
    std::fs::write(&file, fast).unwrap();
    let args = ["--quick", "--paths", "4", "--scene-file", path(&file)];
    let stderr = ran_but_failed(&[&args[..], &["--out", path(&dir)]].concat());
    assert!(stderr.contains("failed on all 4 paths"), "{stderr}");
    assert!(stderr.contains("non-finite 4"), "{stderr}");
    // The report is still written.
    assert!(dir.join("test").join("report.json").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_huge_final_time_is_printed_readably_and_its_failures_exit_1() {
    let dir = folder("huge-t");
    let args = [
        "--quick",
        "--paths",
        "2",
        "--t-end",
        "1e300",
        "--out",
        path(&dir),
    ];
    let stderr = ran_but_failed(&args);
    assert!(stderr.contains("T = 1e300"), "{stderr}");
    assert!(stderr.contains("failed on all 2 paths"), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A built-in scene file under the name "test", with `from` replaced by `to`.
fn edited(built_in: &str, from: &str, to: &str) -> String {
    let text = built_in.replacen("name = \"", "name = \"test\"\n# was \"", 1);
    assert!(text.contains(from), "'{from}' not in the scene");
    text.replace(from, to)
}

/// Writes `text` as a scene file in `dir` and returns its path.
fn scene_file(dir: &Path, text: &str) -> PathBuf {
    let file = dir.join("scene.toml");
    std::fs::write(&file, text).unwrap();
    file
}

/// Writes the built-in pendulum scene, renamed and with `from` replaced by `to` (see
/// [`edited`]), as a scene file in `dir` and returns its path.
fn pendulum_file(dir: &Path, from: &str, to: &str) -> PathBuf {
    scene_file(
        dir,
        &edited(
            include_str!("../../../sdae-study/scenes/pendulum.toml"),
            from,
            to,
        ),
    )
}

/// The equipartition study's command line for the scene file `file`, writing into `dir`.
fn equipartition<'a>(file: &'a Path, dir: &'a Path) -> [&'a str; 5] {
    [
        "equipartition",
        "--scene-file",
        path(file),
        "--out",
        path(dir),
    ]
}

/// The thermal pendulum as a small, fast equipartition scene: 2 paths, N = 4 and 8 over T = 1.
fn small_thermal() -> String {
    edited(
        include_str!("../../../sdae-study/scenes/thermal-pendulum.toml"),
        "T = 64.0\npaths = 400\nlevels = [6, 13]\nburn_in = 16.0\nc_eta = [0.25, 1.0, 4.0, 16.0]",
        "T = 1.0\npaths = 2\nlevels = [2, 3]\nburn_in = 0.5\nc_eta = [1.0]",
    )
}

#[test]
fn sizes_beyond_the_memory_are_refused_naming_the_need_and_the_limit() {
    let dir = folder("sizes");
    let out = ["--out", path(&dir)];
    let huge = "1000000000000";
    usage_error(
        &[&["--quick", "--paths", huge][..], &out].concat(),
        &[
            "--paths 1000000000000",
            "need at least",
            "more than the",
            "available",
        ],
    );
    let file = pendulum_file(&dir, "paths = 10000", &format!("paths = {huge}"));
    let args = [&["--scene-file", path(&file)][..], &out].concat();
    usage_error(
        &args,
        &["study.paths = 1000000000000", "available", path(&file)],
    );
    assert!(!text(&study(&args).stderr).contains("--paths"));
    for (built_in, from, to, key) in [
        (
            include_str!("../../../sdae-study/scenes/chain-molecule.toml"),
            "atoms = 8",
            "atoms = 1000000000000",
            "system.chain-molecule.atoms = 1000000000000",
        ),
        (
            include_str!("../../../sdae-study/scenes/fiber.toml"),
            "beads = 20",
            "beads = 1000000000000",
            "system.fiber.beads = 1000000000000",
        ),
    ] {
        let file = scene_file(&dir, &edited(built_in, from, to));
        usage_error(
            &[&["--scene-file", path(&file), "--quick"][..], &out].concat(),
            &[key, "at most 1000000"],
        );
    }
    // 10^6 beads are built, but 64 paths of every scheme and level at once are not.
    let file = scene_file(
        &dir,
        &edited(
            include_str!("../../../sdae-study/scenes/fiber.toml"),
            "beads = 20",
            "beads = 1000000",
        ),
    );
    usage_error(
        &[
            &[
                "--scene-file",
                path(&file),
                "--quick",
                "--paths",
                "64",
                "--threads",
                "64",
            ][..],
            &out,
        ]
        .concat(),
        &[
            "--threads ",
            "paths in flight (3000000 coordinates",
            "available",
        ],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_absurd_paths_count_in_a_shard_file_is_refused_by_merge() {
    let (dir, file) = folder_with_scene("shard-paths", &scene());
    let args = [
        "--scene-file",
        path(&file),
        "--quick",
        "--paths",
        "4",
        "--levels",
        "2..3",
    ];
    ran(&[&args[..], &["--shard", "0/2", "--out", path(&dir)]].concat());
    let shard = dir.join("test").join("shard-0-of-2.json");
    // Sealed again, with a checksum that fits: the setting itself is refused.
    let mut run = sdae_cli::shards::read_convergence(&shard).unwrap();
    assert_eq!(run.settings.paths, 4);
    run.settings.paths = 1_000_000_000_000;
    sdae_cli::shards::write_convergence(&run, &shard).unwrap();
    usage_error(
        &["merge", path(&dir), "--out", path(&dir.join("merged"))],
        &[
            "shard-0-of-2.json",
            "study.paths",
            "1000000000000",
            "available",
        ],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn threads_are_capped_at_1024_and_not_started_beyond_the_paths() {
    usage_error(&["--threads", "1025"], &["--threads", "at most 1024"]);
    let (dir, file) = folder_with_scene("threads", &scene());
    let args = ["--scene-file", path(&file), "--quick", "--paths", "3"];
    let stderr = ran_into(
        &dir,
        &[&args[..], &["--levels", "2..3", "--threads", "1000"]].concat(),
    );
    assert!(stderr.contains(", 3 threads"), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn fixed_length_arrays_refuse_extra_entries_as_well_as_missing_ones() {
    let dir = folder("arrays");
    for (built_in, key, from, to, message) in wrong_lengths() {
        let file = scene_file(&dir, &edited(built_in, from, &to));
        // The key is in the quoted line of the file.
        usage_error(
            &["--scene-file", path(&file), "--quick", "--out", path(&dir)],
            &[&message, key, path(&file)],
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A built-in scene, a key, the line of the key, the line with an array of the wrong length,
/// and the message that must name it.
type WrongLength = (&'static str, &'static str, &'static str, String, String);

/// Fixed-length arrays of the built-in scenes, one entry too many or too few.
fn wrong_lengths() -> [WrongLength; 9] {
    let pendulum = include_str!("../../../sdae-study/scenes/pendulum.toml");
    let triatomic = include_str!("../../../sdae-study/scenes/triatomic.toml");
    let fiber = include_str!("../../../sdae-study/scenes/fiber.toml");
    let length = |given: usize, expected: usize| {
        format!("invalid length {given}, expected an array of length {expected}")
    };
    let shear = |rows: &str| format!("wind = [1.0, 0.0, 0.0], shear = {rows} }}");
    [
        (
            pendulum,
            "levels",
            "levels = [3, 10]",
            "levels = [3, 10, 12]".into(),
            length(3, 2),
        ),
        (
            pendulum,
            "levels",
            "levels = [3, 10]",
            "levels = [3]".into(),
            length(1, 2),
        ),
        (
            triatomic,
            "levels",
            "levels = [11, 17]",
            "levels = [11, 17, 18]".into(),
            length(3, 2),
        ),
        (
            triatomic,
            "bond_lengths",
            "bond_lengths = [1.0, 1.0, 1.5811388300841898]",
            "bond_lengths = [1.0, 1.0, 1.5811388300841898, 2.0]".into(),
            length(4, 3),
        ),
        (
            triatomic,
            "center",
            "center = [0.0, 0.0, 0.0]",
            "center = [0.0, 0.0, 0.0, 1.0]".into(),
            length(4, 3),
        ),
        (
            fiber,
            "gravity",
            "gravity = [0.0, 0.0, -1.0]",
            "gravity = [0.0, 0.0, -1.0, 5.0]".into(),
            length(4, 3),
        ),
        (
            fiber,
            "wind",
            "wind = [1.0, 0.0, 0.0]",
            "wind = [1.0, 0.0, 0.0, 0.0]".into(),
            length(4, 3),
        ),
        (
            fiber,
            "shear",
            "wind = [1.0, 0.0, 0.0] }",
            shear("[[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]"),
            length(4, 3),
        ),
        (
            fiber,
            "shear",
            "wind = [1.0, 0.0, 0.0] }",
            shear("[[0.0, 0.0, 1.0, 7.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]"),
            length(4, 3),
        ),
    ]
}

#[test]
fn equipartition_exits_1_when_a_setting_lost_every_path_and_counts_the_failures() {
    let (dir, file) = folder_with_scene("equipartition", &small_thermal());
    let args = equipartition(&file, &dir);
    let out = ran(&args);
    assert!(
        text(&out.stdout).contains(" paths failed"),
        "{}",
        text(&out.stdout)
    );
    // |v|^2 overflows: every scheme fails on its first step, on every path.
    let fast = small_thermal().replace("velocity = [0.0, 0.0]", "velocity = [1e200, 0.0]");
    std::fs::write(&file, fast).unwrap();
    let stderr = ran_but_failed(&args);
    assert!(stderr.contains("lost all 2 paths (2 failed)"), "{stderr}");
    let stdout = text(&study(&args).stdout);
    assert!(
        stdout.contains(" paths failed") && !stdout.contains("), 0 of "),
        "{stdout}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn trace_levels_are_bounded() {
    let dir = folder("trace");
    let pendulum = include_str!("../../../sdae-study/scenes/pendulum.toml");
    let file = scene_file(
        &dir,
        &edited(
            pendulum,
            "levels = [3, 10]\nreference = 15",
            "levels = [3, 25]\nreference = 26",
        ),
    );
    usage_error(
        &["trace", "--scene-file", path(&file), "--out", path(&dir)],
        &["study.levels ends at 25", "at most 2^24 steps"],
    );
    // 64 would shift a one-step trace; the scene file itself is refused.
    let file = scene_file(
        &dir,
        &edited(
            pendulum,
            "levels = [3, 10]\nreference = 15",
            "levels = [3, 64]",
        ),
    );
    usage_error(
        &["trace", "--scene-file", path(&file), "--out", path(&dir)],
        &["study.levels = 3..64", path(&file)],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn step_sizes_that_underflow_are_refused_before_running() {
    let dir = folder("underflow");
    usage_error(
        &["--quick", "--t-end", "5e-324", "--out", path(&dir)],
        &[
            "--t-end 5e-324",
            "h = T / 2^",
            "= 0e0 at level",
            "normal float",
        ],
    );
    // From a scene file the key and the file are named, not a flag.
    let file = pendulum_file(&dir, "T = 1.0", "T = 1e-310");
    let args = ["--scene-file", path(&file), "--quick", "--out", path(&dir)];
    usage_error(&args, &["T = 1e-310", "normal float", path(&file)]);
    assert!(!text(&study(&args).stderr).contains("--t-end"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn scene_file_values_are_named_by_their_key_and_file_not_by_a_flag() {
    let dir = folder("provenance");
    let pendulum = include_str!("../../../sdae-study/scenes/pendulum.toml");
    let file = scene_file(&dir, &edited(pendulum, "paths = 10000", "paths = 0"));
    let args = ["--scene-file", path(&file), "--out", path(&dir)];
    usage_error(&args, &["study.paths = 0: must be >= 2", path(&file)]);
    assert!(!text(&study(&args).stderr).contains("--paths"));
    // The equipartition study has no --t-end: its T is named by its key.
    let file = scene_file(
        &dir,
        &small_thermal()
            .replace("T = 1.0\npaths", "T = 1e-310\npaths")
            .replace("burn_in = 0.5", "burn_in = 0.0"),
    );
    let args = equipartition(&file, &dir);
    usage_error(&args, &["equipartition.T = 1e-310", path(&file)]);
    assert!(!text(&study(&args).stderr).contains("--t-end"));
    let file = scene_file(&dir, &small_thermal().replace("paths = 2", "paths = 1"));
    usage_error(
        &equipartition(&file, &dir),
        &["equipartition.paths = 1: must be >= 2", path(&file)],
    );
    // A flag the user typed is named as typed.
    let file = scene_file(&dir, &small_thermal());
    usage_error(
        &[&equipartition(&file, &dir)[..], &["--paths", "1"]].concat(),
        &["--paths 1: must be >= 2"],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn compare_finds_runs_equal_across_thread_counts_and_names_the_first_difference() {
    let dir = folder("compare");
    let run = |threads: &str, out: &str| {
        let out_dir = dir.join(out);
        let args = [
            "--quick",
            "--paths",
            "16",
            "--threads",
            threads,
            "--out",
            path(&out_dir),
        ];
        ran(&args);
        out_dir.join("pendulum").join("report.json")
    };
    let (one, two) = (run("1", "one"), run("2", "two"));
    let same = ran(&["compare", path(&one), path(&two)]);
    assert!(text(&same.stdout).contains("hold the same numbers"));

    // One number changed in its ninth digit: exit 1, the number named by its JSON pointer.
    let json = std::fs::read_to_string(&one).unwrap();
    let at = json.find("\"estimate\": ").unwrap() + "\"estimate\": ".len();
    let end = at + json[at..].find([',', '\n', '}']).unwrap();
    let value: f64 = json[at..end].trim().parse().unwrap();
    let changed = value + 1e-9 * value.abs().max(1.0);
    let other = dir.join("other.json");
    let edited = format!("{}{changed:?}{}", &json[..at], &json[end..]);
    std::fs::write(&other, edited).unwrap();
    let stderr = ran_but_failed(&["compare", path(&one), path(&other)]);
    assert!(
        stderr.contains("differ at /") && stderr.contains("/estimate: "),
        "{stderr}"
    );

    usage_error(
        &["compare", path(&one), path(&dir.join("missing.json"))],
        &["cannot read", "missing.json"],
    );
    usage_error(&["compare", path(&one)], &["<B>"]);
}

#[test]
fn checkpoint_intervals_beyond_a_year_are_refused_by_every_subcommand() {
    let dir = folder("interval");
    for study in ["convergence", "stability", "equipartition", "weak", "mlmc"] {
        usage_error(
            &[
                study,
                "--checkpoint-every",
                "2e19",
                "--quick",
                "--out",
                path(&dir),
            ],
            &["--checkpoint-every", "at most 31536000 seconds (a year)"],
        );
    }
    usage_error(
        &["--checkpoint-every", "31536001", "--out", path(&dir)],
        &["--checkpoint-every", "a year"],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn weak_table_settings_are_named_by_their_key_and_file() {
    let dir = folder("weak-keys");
    let pendulum = include_str!("../../../sdae-study/scenes/pendulum.toml");
    // The [study] table's paths are 10000: the [weak] table's 0 is the one named.
    for (from, to, words) in [
        ("paths = 40000", "paths = 0", "weak.paths = 0: must be >= 2"),
        ("paths = 40000", "paths = 1", "weak.paths = 1: must be >= 2"),
        (
            "levels = [2, 7]\nreference = 11",
            "levels = [2, 7]\nreference = 30",
            "weak.reference = 30",
        ),
        (
            "levels = [2, 7]\nreference = 11",
            "levels = [2, 7]\nreference = 5",
            "weak.reference = 5",
        ),
        (
            "levels = [2, 7]\nreference = 11",
            "levels = [2, 40]",
            "weak.levels = 2..40",
        ),
        (
            "levels = [2, 7]\nreference = 11",
            "levels = [9, 10]",
            "weak.levels = 9..10",
        ),
    ] {
        let file = scene_file(&dir, &edited(pendulum, from, to));
        let args = ["weak", "--scene-file", path(&file), "--out", path(&dir)];
        usage_error(&args, &[words, path(&file)]);
        let stderr = text(&study(&args).stderr);
        assert!(!stderr.contains("study."), "{stderr}");
        assert!(!stderr.contains("--paths"), "{stderr}");
    }
    // A flag the user typed is still named as typed.
    usage_error(
        &["weak", "--paths", "1", "--quick", "--out", path(&dir)],
        &["--paths 1: must be >= 2"],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_bad_system_in_a_later_scene_stops_the_command_before_the_first_scene_runs() {
    let dir = folder("later-scene");
    let file = pendulum_file(&dir, "gravity = 1.0", "gravity = nan");
    for study in ["convergence", "weak", "trace"] {
        let mut args = vec![study, "--scene", "pendulum", "--scene-file", path(&file)];
        if study != "trace" {
            args.extend(["--quick", "--paths", "4"]);
        }
        args.extend(["--out", path(&dir)]);
        usage_error(&args, &["gravity", path(&file)]);
        let out = study_output(&args);
        assert!(!out.contains("wrote"), "{study}: {out}");
        assert!(
            !dir.join("pendulum").exists(),
            "{study} ran the first scene"
        );
        assert!(!dir.join("trace").exists(), "{study} ran the first scene");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// What a run printed on stdout.
fn study_output(args: &[&str]) -> String {
    text(&study(args).stdout)
}

#[test]
fn final_times_whose_errors_would_underflow_are_refused_before_running() {
    let dir = folder("tiny-t");
    for t in ["1e-160", "1e-300"] {
        usage_error(
            &["--quick", "--t-end", t, "--out", path(&dir)],
            &[&format!("--t-end {t}"), "h = T / 2^", "2^-511"],
        );
        usage_error(
            &["mlmc", "--quick", "--t-end", t, "--out", path(&dir)],
            &[&format!("--t-end {t}"), "2^-511"],
        );
    }
    usage_error(
        &["mlmc", "--quick", "--t-end", "5e-324", "--out", path(&dir)],
        &["--t-end 5e-324", "2^-511"],
    );
    assert!(!dir.join("pendulum").exists() && !dir.join("mlmc").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn distances_a_plot_cannot_draw_are_left_out_and_the_plots_are_written() {
    let dir = folder("extreme-distance");
    let shards = dir.join("shards");
    ran(&[
        "--quick",
        "--paths",
        "4",
        "--threads",
        "1",
        "--shard",
        "0/1",
        "--out",
        path(&shards),
    ]);
    let file = shards.join("pendulum").join("shard-0-of-1.json");
    let shard = sdae_cli::shards::read_convergence(&file).unwrap();
    for value in [1e308, 1e-310] {
        // Edited through the library, which seals the file again with its checksum.
        let mut edited = shard.clone();
        let distances = edited.records[0].tracks[4].distances.as_mut().unwrap();
        distances[0] = value;
        let input = dir.join(format!("in-{value:e}"));
        std::fs::create_dir_all(&input).unwrap();
        sdae_cli::shards::write_convergence(&edited, &input.join("shard-0-of-1.json")).unwrap();
        let out = dir.join(format!("out-{value:e}"));
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_sdae-study"))
            .args(["merge", path(&input), "--out", path(&out)])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let start = std::time::Instant::now();
        let status = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break status;
            }
            if start.elapsed() > std::time::Duration::from_secs(60) {
                let _ = child.kill();
                panic!("merge with a distance of {value:e} still running after 60 s");
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        };
        let mut stderr = String::new();
        std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut stderr).unwrap();
        assert_eq!(status.code(), Some(0), "{value:e}: {stderr}");
        for svg in ["error_vs_h.svg", "error_vs_time.svg"] {
            assert!(out.join("pendulum").join(svg).exists(), "{svg} missing");
        }
        if value > 1.0 {
            assert!(
                stderr.contains("left out of the plot") && stderr.contains("1e300"),
                "{stderr}"
            );
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn errors_that_underflow_are_named_unresolved_not_fitted() {
    // At T = 1e-100 a step moves the state by less than its rounding: the velocity errors of
    // the half-explicit schemes are exactly 0.
    let dir = folder("zero-errors");
    let stderr = ran_into(
        &dir,
        &[
            "--quick",
            "--paths",
            "8",
            "--threads",
            "1",
            "--schemes",
            "half-explicit-practical",
            "--t-end",
            "1e-100",
        ],
    );
    assert!(stderr.contains("underflowed"), "{stderr}");
    let md = std::fs::read_to_string(dir.join("pendulum").join("report.md")).unwrap();
    assert!(
        md.contains("Not fitted, unresolved") && md.contains("v at N = 8 (error 0e0)"),
        "{md}"
    );
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("pendulum").join("report.json")).unwrap(),
    )
    .unwrap();
    let scheme = &json["schemes"][0];
    let unresolved = scheme["unresolved"].as_array().unwrap();
    assert!(unresolved.iter().any(|u| u["output"] == "v"), "{scheme}");
    assert!(scheme["observed_order"]["v"].is_null(), "{scheme}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn weak_errors_that_underflow_give_no_order() {
    // At T = 1e-140 every weak error is exactly 0: no order is fitted to them.
    let dir = folder("zero-weak-errors");
    let file = pendulum_file(&dir, "T = 1.0", "T = 1e-140");
    ran(&[
        "weak",
        "--quick",
        "--paths",
        "16",
        "--threads",
        "1",
        "--scene-file",
        path(&file),
        "--out",
        path(&dir),
    ]);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("test").join("weak.json")).unwrap())
            .unwrap();
    for o in json["observables"].as_array().unwrap() {
        for s in o["schemes"].as_array().unwrap() {
            assert!(s["order"].is_null(), "{}: {}", o["name"], s["order"]);
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
