//! `simulate`: the files hold the library's paths bit for bit whatever the format and threads;
//! what cannot be written is refused before anything runs (exit code 2), naming the flag and
//! its value; a stopped run keeps whole frames (exit code 130) and no temporary file.

use crate::cli;
use crate::common::scratch;
use crate::process;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use cli::{ran, study, text, usage_error};
use sdae_study::integrator::SchemeKind;
use sdae_study::scene::Scene;
use sdae_study::simulate::{SimulateSettings, simulate};

/// The numbers of a CSV row.
fn row(line: &str) -> Vec<f64> {
    line.split(',').map(|x| x.parse().unwrap()).collect()
}

#[test]
fn the_files_hold_the_librarys_paths_bit_for_bit() {
    // 70 paths on two threads: blocks of 64 and 6, as the library's arrays have them.
    let dir = scratch("simulate-csv");
    let out = dir.to_str().unwrap();
    let common = [
        "simulate",
        "--scene",
        "spherical-pendulum",
        "--paths",
        "70",
        "--steps",
        "40",
        "--every",
        "16",
        "--seed",
        "11",
        "--threads",
        "2",
        "--out",
        out,
    ];
    ran(&[&common[..], &["--format", "csv"]].concat());
    let scene = Scene::built_in("spherical-pendulum").unwrap();
    let settings = SimulateSettings::new(SchemeKind::HalfExplicitPractical, 70, 40, 11)
        .unwrap()
        .every(16)
        .unwrap();
    let paths = simulate(&scene, &settings, &|| false).unwrap();
    let folder = dir.join("simulate/spherical-pendulum");
    let csv = std::fs::read_to_string(folder.join("spherical-pendulum.csv")).unwrap();
    let rows: Vec<Vec<f64>> = csv.lines().skip(1).map(row).collect();
    let times = paths.times.len();
    assert_eq!(rows.len(), 70 * times);
    for r in &rows {
        let (p, step) = (r[0] as usize, r[1] as usize);
        let j = settings
            .recorded_steps()
            .iter()
            .position(|&k| k == step)
            .unwrap();
        assert_eq!(r[2], paths.times[j]);
        assert_eq!(
            r[3..],
            paths.positions[(p * times + j) * 3..][..3],
            "path {p} step {step}"
        );
    }
    // The default format of a particle system: a file per path.
    let said = text(&ran(&common).stdout);
    assert!(said.contains("wrote 70 xyz files"), "{said}");
    let xyz = std::fs::read_to_string(folder.join("spherical-pendulum.path-69.xyz")).unwrap();
    let last = xyz.lines().last().unwrap();
    let values: Vec<f64> = last
        .split(' ')
        .skip(1)
        .map(|x| x.parse().unwrap())
        .collect();
    let at = (69 * times + times - 1) * 3;
    assert_eq!(values[..3], paths.positions[at..at + 3]);
    assert_eq!(values[3..], paths.velocities[at..at + 3]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn what_cannot_be_written_is_refused_before_anything_runs() {
    let dir = scratch("simulate-refused");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("a-file");
    std::fs::write(&file, "x").unwrap();
    let out = dir.to_str().unwrap();
    let cases: [(&[&str], &[&str]); 5] = [
        (
            &["--format", "vtk", "--out", out],
            &[
                "--format vtk",
                "pendulum",
                "one particle in 2-D",
                "use xyz or csv",
            ],
        ),
        (&["--out", file.to_str().unwrap()], &["--out", "a-file"]),
        (
            &[
                "--paths", "100000", "--steps", "1000000", "--every", "1", "--out", out,
            ],
            &["--paths 100000", "1000001 recorded times", "free on"],
        ),
        (
            &[
                "--scene",
                "long-fiber",
                "--paths",
                "100000000",
                "--out",
                out,
            ],
            &[
                "--paths 100000000",
                "the paths in flight need at least",
                "available",
            ],
        ),
        (
            &["--scene", "pendulum", "--scene", "fiber", "--out", out],
            &["one --scene or one --scene-file"],
        ),
    ];
    for (args, words) in cases {
        usage_error(&[&["simulate"], args].concat(), words);
    }
    let written = |dir: &Path| {
        walk(dir)
            .iter()
            .any(|f| f.to_string_lossy().contains("simulate/"))
    };
    assert!(!written(&dir), "{:?}", walk(&dir));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every file under `dir`.
fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        if path.is_dir() {
            files.extend(walk(&path));
        } else {
            files.push(path);
        }
    }
    files
}

#[test]
fn a_stopped_run_keeps_whole_frames_and_no_temporary_file() {
    let dir = scratch("simulate-stopped");
    let child = process::binary()
        .args([
            "simulate",
            "--paths",
            "2",
            "--steps",
            "400000000",
            "--every",
            "1000",
        ])
        .args(["--out", dir.to_str().unwrap()])
        .spawn()
        .unwrap();
    let folder = dir.join("simulate/pendulum");
    let start = Instant::now();
    // The files of path 0 being written (not the folder's write check, `.write-check.*.tmp`).
    let writing = |f: &PathBuf| {
        let name = f.to_string_lossy();
        name.contains("pendulum.path-0.xyz.") && name.ends_with(".tmp")
    };
    while !walk(&dir).iter().any(writing) {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no frames written"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(200));
    process::signal(&child, "INT");
    let out = child.wait_with_output().unwrap();
    let stderr = process::stderr(&out);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(
        stderr.contains("frames written before the stop"),
        "{stderr}"
    );
    assert!(
        process::leftovers(&folder).is_empty(),
        "{:?}",
        process::leftovers(&folder)
    );
    for p in 0..2 {
        let xyz = std::fs::read_to_string(folder.join(format!("pendulum.path-{p}.xyz"))).unwrap();
        let lines: Vec<&str> = xyz.lines().collect();
        assert!(
            !lines.is_empty() && lines.len().is_multiple_of(3),
            "{} lines",
            lines.len()
        );
        for (j, frame) in lines.chunks(3).enumerate() {
            assert!(
                frame[1].contains(&format!(" step={} path={p} ", 1000 * j)),
                "{}",
                frame[1]
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_fibers_default_is_a_vtk_series() {
    let dir = scratch("simulate-vtk");
    let out = ran(&[
        "simulate",
        "--scene",
        "fiber",
        "--paths",
        "2",
        "--steps",
        "512",
        "--every",
        "256",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let said = text(&out.stdout);
    assert!(
        said.contains("wrote 4 vtk files") && said.contains("fiber.pvd in ParaView"),
        "{said}"
    );
    let pvd = std::fs::read_to_string(dir.join("simulate/fiber/fiber.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet ").count(), 3);
    assert_eq!(study(&["simulate", "--help"]).status.code(), Some(0));
    let _ = std::fs::remove_dir_all(&dir);
}
