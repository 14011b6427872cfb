//! The writers read back: frame counts, every digit of the numbers, the files' order, the
//! refusals.

use super::*;
use crate::integrator::SchemeKind;
use crate::simulate::{SimulateSettings, SimulatedPaths, simulate};

/// A fresh folder for one test.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sdae-trajectory-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// `paths` paths of `scene`, 4 * 8 steps recorded every 8th (5 times; a fiber's steps are 16
/// times finer, where none fails), seed 3.
fn simulated(scene: &str, paths: usize) -> (Scene, SimulatedPaths) {
    let every = if scene == "fiber" { 128 } else { 8 };
    let scene = Scene::built_in(scene).unwrap();
    let settings = SimulateSettings::new(SchemeKind::HalfExplicitPractical, paths, 4 * every, 3)
        .unwrap()
        .every(every)
        .unwrap();
    let paths = simulate(&scene, &settings, &|| false).unwrap();
    assert!(paths.failures.iter().all(Option::is_none));
    (scene, paths)
}

/// Path p's state at recorded time j, as `(r, v)`.
fn state(paths: &SimulatedPaths, p: usize, j: usize) -> (&[f64], &[f64]) {
    let at = (p * paths.times.len() + j) * paths.n;
    (
        &paths.positions[at..at + paths.n],
        &paths.velocities[at..at + paths.n],
    )
}

fn numbers(line: &str) -> Vec<f64> {
    line.split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect()
}

#[test]
fn numbers_read_back_to_the_same_bits() {
    for x in [
        0.0,
        -0.0,
        1.0,
        0.1,
        -1.0 / 3.0,
        1e-300,
        f64::MIN_POSITIVE,
        5e-324,
        1e8 / 7.0,
        1e16,
        -2.5e300,
        f64::MAX,
        std::f64::consts::PI,
    ] {
        let text = number(x);
        assert_eq!(
            text.parse::<f64>().unwrap().to_bits(),
            x.to_bits(),
            "{x}: {text}"
        );
        assert!(text.len() <= NUMBER_BYTES as usize, "{text}");
    }
}

#[test]
fn xyz_has_a_file_per_path_a_frame_per_time_and_every_digit() {
    let (scene, paths) = simulated("pendulum", 3);
    let dir = folder("xyz");
    let files = write_paths(&paths, &scene, TrajectoryFormat::Xyz, &dir).unwrap();
    assert_eq!(files.len(), 3);
    for (p, file) in files.iter().enumerate() {
        assert_eq!(file, &dir.join(format!("pendulum.path-{p}.xyz")));
        let text = std::fs::read_to_string(file).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        // A frame: the count, the comment, one particle.
        assert_eq!(lines.len(), 3 * paths.times.len());
        for (j, frame) in lines.chunks(3).enumerate() {
            assert_eq!(frame[0], "1");
            let comment = frame[1];
            assert!(
                comment.starts_with("Properties=species:S:1:pos:R:3:vel:R:3 "),
                "{comment}"
            );
            assert!(!comment.contains("Lattice"));
            let time = format!("time={} step={} path={p} ", number(paths.times[j]), 8 * j);
            assert!(comment.contains(&time), "{comment}");
            assert!(comment.ends_with("scheme=half-explicit-practical"));
            let (species, values) = frame[2].split_once(' ').unwrap();
            assert_eq!(species, "X");
            let (r, v) = state(&paths, p, j);
            // The planar pendulum's bob padded with z = 0, bit for bit.
            assert_eq!(numbers(values), [r[0], r[1], 0.0, v[0], v[1], 0.0]);
        }
    }
    assert_no_temporaries(&dir);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn xyz_files_beyond_the_open_limit_are_reopened_to_append() {
    // Time-major frames of more paths than files may be open: every path's file is closed
    // and reopened between its frames, and still holds its frames in order.
    let scene = Scene::built_in("spherical-pendulum").unwrap();
    let dir = folder("xyz-many");
    let mut writer = TrajectoryWriter::create(TrajectoryFormat::Xyz, &scene, "s", &dir).unwrap();
    let paths = MAX_OPEN_FILES + 5;
    for step in 0..3 {
        for path in 0..paths {
            let r = [path as f64, step as f64, 0.5];
            let frame = Frame {
                path,
                step,
                time: step as f64,
                position: &r,
                velocity: &[0.0; 3],
            };
            writer.write_frame(&frame).unwrap();
        }
    }
    let files = writer.finish().unwrap();
    assert_eq!(files.len(), paths);
    for (path, file) in files.iter().enumerate() {
        let text = std::fs::read_to_string(file).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 9);
        for step in 0..3 {
            let values = numbers(lines[3 * step + 2].split_once(' ').unwrap().1);
            assert_eq!(values[..3], [path as f64, step as f64, 0.5]);
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn vtk_has_a_grid_per_time_with_every_path_and_a_collection() {
    let (scene, paths) = simulated("fiber", 2);
    let dir = folder("vtk");
    let files = write_paths(&paths, &scene, TrajectoryFormat::Vtk, &dir).unwrap();
    let times = paths.times.len();
    assert_eq!(files.len(), 1 + times);
    assert_eq!(files[0], dir.join("fiber.pvd"));
    let pvd = std::fs::read_to_string(&files[0]).unwrap();
    assert_eq!(pvd.matches("<DataSet ").count(), times);
    let beads = paths.n / 3;
    for (j, file) in files[1..].iter().enumerate() {
        assert_eq!(file, &dir.join(format!("fiber.{j:06}.vtu")));
        let entry = format!(
            "timestep=\"{}\" group=\"\" part=\"0\" file=\"fiber.{j:06}.vtu\"",
            number(paths.times[j])
        );
        assert!(pvd.contains(&entry), "{pvd}");
        let text = std::fs::read_to_string(file).unwrap();
        let piece = format!("NumberOfPoints=\"{}\" NumberOfCells=\"2\"", 2 * beads);
        assert!(text.contains(&piece));
        let points = array(&text, "Name=\"position\"");
        let velocities = array(&text, "Name=\"velocity\"");
        for p in 0..2 {
            let (r, v) = state(&paths, p, j);
            assert_eq!(&points[p * paths.n..][..paths.n], r);
            assert_eq!(&velocities[p * paths.n..][..paths.n], v);
        }
        let offsets = array(&text, "Name=\"offsets\"");
        assert_eq!(offsets, [beads as f64, 2.0 * beads as f64]);
        assert_eq!(array(&text, "Name=\"types\""), [4.0, 4.0]);
        assert_eq!(array(&text, "Name=\"path\""), [0.0, 1.0]);
        assert_eq!(array(&text, "Name=\"TimeValue\""), [paths.times[j]]);
    }
    assert_no_temporaries(&dir);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The numbers of the data array whose opening tag holds `name`.
fn array(text: &str, name: &str) -> Vec<f64> {
    let start = text.find(name).unwrap();
    let body = &text[start..];
    let body = &body[body.find('>').unwrap() + 1..body.find("</DataArray>").unwrap()];
    numbers(body)
}

#[test]
fn csv_has_a_row_per_path_and_time_with_every_digit() {
    let (scene, paths) = simulated("triatomic", 2);
    let dir = folder("csv");
    let files = write_paths(&paths, &scene, TrajectoryFormat::Csv, &dir).unwrap();
    assert_eq!(files, [dir.join("triatomic.csv")]);
    let text = std::fs::read_to_string(&files[0]).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header[..4], ["path", "step", "time", "r_0"]);
    assert_eq!(header.len(), 3 + 9);
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 2 * paths.times.len());
    for (k, row) in rows.iter().enumerate() {
        let (p, j) = (k / paths.times.len(), k % paths.times.len());
        assert_eq!(row[..3], [p as f64, (8 * j) as f64, paths.times[j]]);
        assert_eq!(&row[3..], state(&paths, p, j).0);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

fn assert_no_temporaries(dir: &Path) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name();
        assert!(!name.to_string_lossy().ends_with(".tmp"), "{name:?}");
    }
}

#[test]
fn a_writer_dropped_before_finishing_leaves_no_files() {
    let (scene, paths) = simulated("fiber", 1);
    for format in TrajectoryFormat::ALL {
        let dir = folder(&format!("dropped-{}", format.name()));
        let mut writer = TrajectoryWriter::create(format, &scene, "s", &dir).unwrap();
        for j in 0..paths.times.len() {
            let (r, v) = state(&paths, 0, j);
            let frame = Frame {
                path: 0,
                step: j,
                time: paths.times[j],
                position: r,
                velocity: v,
            };
            writer.write_frame(&frame).unwrap();
        }
        drop(writer);
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            0,
            "{}",
            format.name()
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn vtk_refuses_a_system_without_a_chain_and_frames_out_of_time_order() {
    for name in ["pendulum", "spherical-pendulum", "triatomic"] {
        let scene = Scene::built_in(name).unwrap();
        let refused = TrajectoryWriter::create(TrajectoryFormat::Vtk, &scene, "s", &folder("no"))
            .unwrap_err();
        let StudyError::Setting { key, value, rule } = &refused else {
            panic!("{refused}")
        };
        assert_eq!((*key, value.as_str()), ("format", "vtk"));
        assert!(
            rule.contains("use xyz or csv") && rule.contains(name),
            "{rule}"
        );
    }
    let scene = Scene::built_in("chain-molecule").unwrap();
    let dir = folder("vtk-order");
    let mut writer = TrajectoryWriter::create(TrajectoryFormat::Vtk, &scene, "s", &dir).unwrap();
    let r = vec![0.0; 24];
    let frame = |step: usize| Frame {
        path: 0,
        step,
        time: step as f64,
        position: &r,
        velocity: &r,
    };
    writer.write_frame(&frame(0)).unwrap();
    writer.write_frame(&frame(1)).unwrap();
    let refused = writer.write_frame(&frame(0)).unwrap_err();
    assert!(
        refused
            .to_string()
            .contains("frames of one time come together"),
        "{refused}"
    );
    let short = Frame {
        position: &r[..3],
        ..frame(2)
    };
    let refused = writer.write_frame(&short).unwrap_err();
    assert!(
        refused.to_string().contains("system's 24 coordinates"),
        "{refused}"
    );
    drop(writer);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn defaults_and_names_of_the_formats() {
    let format = |name| TrajectoryFormat::default_for(&Scene::built_in(name).unwrap());
    assert_eq!(format("fiber"), TrajectoryFormat::Vtk);
    assert_eq!(format("chain-molecule"), TrajectoryFormat::Xyz);
    assert_eq!(format("pendulum"), TrajectoryFormat::Xyz);
    for f in TrajectoryFormat::ALL {
        assert_eq!(TrajectoryFormat::from_name(f.name()), Some(f));
    }
    assert_eq!(TrajectoryFormat::from_name("vtp"), None);
}

#[test]
fn the_estimate_bounds_the_bytes_written_and_a_full_disk_refuses() {
    let (scene, paths) = simulated("fiber", 3);
    let particles = Particles::of(&scene).unwrap();
    for format in TrajectoryFormat::ALL {
        let dir = folder(&format!("size-{}", format.name()));
        let files = write_paths(&paths, &scene, format, &dir).unwrap();
        let written: u64 = files.iter().map(|f| f.metadata().unwrap().len()).sum();
        let estimate = estimated_bytes(format, &particles, 3, paths.times.len());
        assert!(
            written <= estimate,
            "{}: {written} > {estimate}",
            format.name()
        );
        assert!(
            written * 4 >= estimate,
            "{}: {written} << {estimate}",
            format.name()
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
    let free = free_space(&std::env::temp_dir()).expect("statvfs answers on Linux");
    assert!(free > 0);
    let settings =
        SimulateSettings::new(SchemeKind::HalfExplicitPractical, 1 << 40, 1 << 20, 1).unwrap();
    let refused = check_room(
        TrajectoryFormat::Csv,
        &particles,
        &settings,
        &folder("full"),
    )
    .unwrap_err();
    let StudyError::Setting { key, rule, .. } = &refused else {
        panic!("{refused}")
    };
    assert_eq!(*key, "paths");
    assert!(
        rule.contains("csv files of 1099511627776 paths x 1048577 recorded times need about"),
        "{rule}"
    );
    assert!(rule.contains("free on"), "{rule}");
}
