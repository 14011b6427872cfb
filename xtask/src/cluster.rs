//! `cargo xtask cluster-check`: the Slurm recipe of docs/cluster.md, run for real on a
//! one-node cluster on this machine.
//!
//! Installs `slurm-wlm` and `munge` from the Debian packages if they are missing (as root),
//! starts munged (unless one answers already), slurmctld and slurmd with a configuration in
//! `<target>/cluster-check/`, submits the `--quick` convergence study as a 4-task job array
//! with `--shard auto`, waits for it, merges the shards, checks that the merged report equals
//! the unsharded run's number for number, and stops the daemons it started (by their pids),
//! also when a step fails.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::{TaskError, target_dir, workspace_root};

/// Tasks of the job array.
const TASKS: usize = 4;
/// How long the array may take (the quick study takes seconds).
const ARRAY_TIMEOUT: Duration = Duration::from_secs(600);

fn failed(message: impl Into<String>) -> TaskError {
    TaskError::Failed(message.into())
}

/// Runs `program args`, failing with its output when it does not succeed.
fn run(program: &str, args: &[&str], env: &[(&str, &Path)]) -> Result<String, TaskError> {
    let mut command = Command::new(program);
    command.args(args);
    for (key, value) in env {
        command.env(key, value);
    }
    let out = command
        .output()
        .map_err(|e| failed(format!("cannot run {program}: {e}")))?;
    if !out.status.success() {
        return Err(failed(format!(
            "{program} {} failed ({}):\n{}{}",
            args.join(" "),
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        )));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

fn on_path(program: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {program}")])
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Installs the Debian packages of Slurm and munge unless their programs are there.
fn install() -> Result<(), TaskError> {
    let needed = ["slurmctld", "slurmd", "sbatch", "munged"];
    if needed.iter().all(|p| on_path(p)) {
        return Ok(());
    }
    if run("id", &["-u"], &[])?.trim() != "0" {
        return Err(failed(
            "slurm-wlm and munge are missing and installing them needs root",
        ));
    }
    eprintln!("installing slurm-wlm and munge from the Debian packages");
    let install = [
        "install",
        "-y",
        "-q",
        "--no-install-recommends",
        "slurm-wlm",
        "munge",
    ];
    let apt = |args: &[&str]| {
        Command::new("apt-get")
            .args(args)
            .env("DEBIAN_FRONTEND", "noninteractive")
            .stdout(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    // A fresh machine may have no package lists yet: update them and try once more.
    let installed = apt(&install) || (apt(&["update", "-q"]) && apt(&install));
    if !installed {
        return Err(failed("apt-get could not install slurm-wlm and munge"));
    }
    Ok(())
}

/// Daemons this task started, stopped by their pids when it ends (whatever happens).
#[derive(Default)]
struct Daemons {
    pid_files: Vec<PathBuf>,
}

impl Daemons {
    /// Remembers a daemon by its pid file (it is stopped later).
    fn started(&mut self, pid_file: PathBuf) {
        self.pid_files.push(pid_file);
    }
}

impl Drop for Daemons {
    fn drop(&mut self) {
        for file in self.pid_files.iter().rev() {
            let Ok(text) = std::fs::read_to_string(file) else {
                eprintln!(
                    "warning: no pid in {}; the daemon may still run",
                    file.display()
                );
                continue;
            };
            let pid = text.trim().to_string();
            let stopped = Command::new("kill").arg(&pid).status();
            if !stopped.is_ok_and(|s| s.success()) {
                eprintln!("warning: could not stop pid {pid} ({})", file.display());
                continue;
            }
            // Gone, or a zombie nobody reaps: either way it has stopped.
            let running = || {
                std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|stat| {
                    stat.rsplit(')')
                        .next()
                        .is_some_and(|s| !s.trim_start().starts_with('Z'))
                })
            };
            if wait_for("a daemon to stop", Duration::from_secs(10), || !running()).is_err() {
                eprintln!(
                    "warning: pid {pid} ({}) did not stop within 10 s",
                    file.display()
                );
            }
        }
    }
}

/// Waits until `ready` holds, checking every 200 ms.
fn wait_for(what: &str, timeout: Duration, ready: impl Fn() -> bool) -> Result<(), TaskError> {
    let start = Instant::now();
    while !ready() {
        if start.elapsed() > timeout {
            return Err(failed(format!(
                "timed out after {timeout:?} waiting for {what}"
            )));
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    Ok(())
}

/// The one-node configuration: this host, all its cores, daemons running as root, state,
/// logs and pid files under `dir`.
fn slurm_conf(dir: &Path, host: &str, cpus: usize) -> String {
    let d = dir.display();
    format!(
        "ClusterName=sdae-check\n\
         SlurmctldHost={host}\n\
         AuthType=auth/munge\n\
         CredType=cred/munge\n\
         ProctrackType=proctrack/linuxproc\n\
         TaskPlugin=task/none\n\
         SelectType=select/cons_tres\n\
         SelectTypeParameters=CR_Core\n\
         SlurmUser=root\n\
         SlurmdUser=root\n\
         StateSaveLocation={d}/state\n\
         SlurmdSpoolDir={d}/spool\n\
         SlurmctldPidFile={d}/slurmctld.pid\n\
         SlurmdPidFile={d}/slurmd.pid\n\
         SlurmctldLogFile={d}/slurmctld.log\n\
         SlurmdLogFile={d}/slurmd.log\n\
         ReturnToService=2\n\
         MpiDefault=none\n\
         JobAcctGatherType=jobacct_gather/none\n\
         AccountingStorageType=accounting_storage/none\n\
         NodeName={host} CPUs={cpus} State=UNKNOWN\n\
         PartitionName=check Nodes={host} Default=YES MaxTime=INFINITE State=UP\n"
    )
}

/// The job array of docs/cluster.md: every task runs its shard of the quick study.
fn array_script(study: &Path, out: &Path) -> String {
    format!(
        "#!/bin/bash\n\
         #SBATCH --job-name=sdae-study\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --cpus-per-task=1\n\
         exec {study} --quick --threads 1 --shard auto --out {out}\n",
        last = TASKS - 1,
        study = study.display(),
        out = out.display()
    )
}

/// Starts munged unless one answers already.
fn munge(daemons: &mut Daemons) -> Result<(), TaskError> {
    let answers = || {
        Command::new("sh")
            .args(["-c", "munge -n | unmunge"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    if answers() {
        return Ok(());
    }
    std::fs::create_dir_all("/run/munge").map_err(|e| failed(format!("/run/munge: {e}")))?;
    run("munged", &["--force"], &[])?;
    daemons.started(PathBuf::from("/run/munge/munged.pid"));
    wait_for("munged", Duration::from_secs(10), answers)
}

/// Runs the check.
pub fn run_check(args: &[String]) -> Result<(), TaskError> {
    if let Some(extra) = args.first() {
        return Err(TaskError::Usage(format!(
            "cluster-check takes no options, got `{extra}`"
        )));
    }
    let target = target_dir()?;
    let study = build_study(&target)?;
    install()?;
    let dir = target.join("cluster-check");
    let _ = std::fs::remove_dir_all(&dir);
    for sub in ["state", "spool", "array", "single", "merged"] {
        std::fs::create_dir_all(dir.join(sub))
            .map_err(|e| failed(format!("cannot create {}: {e}", dir.display())))?;
    }
    let host = run("hostname", &["-s"], &[])?.trim().to_string();
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    let conf = dir.join("slurm.conf");
    let script = dir.join("study-array.sbatch");
    let write = |path: &Path, text: String| {
        std::fs::write(path, text).map_err(|e| failed(format!("{}: {e}", path.display())))
    };
    write(&conf, slurm_conf(&dir, &host, cpus))?;
    write(&script, array_script(&study, &dir.join("array")))?;

    let daemons = start_cluster(&dir, &conf)?;
    eprintln!("one-node cluster up on {host} ({cpus} CPUs); submitting a {TASKS}-task array");
    run_array(&dir, &script, &conf)?;
    let merged = merge_and_compare(&study, &dir)?;
    drop(daemons);
    println!(
        "cluster-check passed: {TASKS} Slurm array tasks merged to exactly the unsharded \
         report ({})",
        merged.join("pendulum").join("report.json").display()
    );
    Ok(())
}

/// Builds the study binary in release mode; its path.
fn build_study(target: &Path) -> Result<PathBuf, TaskError> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    eprintln!("building sdae-study (release)");
    let built = Command::new(cargo)
        .current_dir(workspace_root()?)
        .args(["build", "--release", "--quiet", "-p", "sdae-cli"])
        .env("CARGO_TARGET_DIR", target)
        .status()
        .map_err(|e| failed(format!("cannot start cargo: {e}")))?;
    if !built.success() {
        return Err(failed(format!("building sdae-study failed ({built})")));
    }
    Ok(target.join("release").join("sdae-study"))
}

/// Starts munged, slurmctld and slurmd with the configuration `conf` and waits for the node;
/// the daemons stop when the returned value is dropped.
fn start_cluster(dir: &Path, conf: &Path) -> Result<Daemons, TaskError> {
    let mut daemons = Daemons::default();
    munge(&mut daemons)?;
    let env = [("SLURM_CONF", conf)];
    let conf_arg = conf.display().to_string();
    run("slurmctld", &["-f", &conf_arg], &env)?;
    daemons.started(dir.join("slurmctld.pid"));
    run("slurmd", &["-f", &conf_arg], &env)?;
    daemons.started(dir.join("slurmd.pid"));
    wait_for("the node to be idle", Duration::from_secs(60), || {
        run("sinfo", &["-h", "-o", "%t"], &env).is_ok_and(|s| s.trim() == "idle")
    })?;
    Ok(daemons)
}

/// Submits the job array `script`, waits for it and checks that every task wrote its shard
/// (a task that did not is named with its log).
fn run_array(dir: &Path, script: &Path, conf: &Path) -> Result<(), TaskError> {
    let env = [("SLURM_CONF", conf)];
    let log = dir.join("task-%a.log").display().to_string();
    let job = run(
        "sbatch",
        &[
            "--parsable",
            "--output",
            &log,
            &script.display().to_string(),
        ],
        &env,
    )?;
    let job = job.trim().to_string();
    wait_for("the job array", ARRAY_TIMEOUT, || {
        run("squeue", &["-h", "-j", &job], &env).is_ok_and(|s| s.trim().is_empty())
    })?;
    let shards = dir.join("array").join("pendulum");
    for i in 0..TASKS {
        let file = shards.join(format!("shard-{i}-of-{TASKS}.json"));
        if !file.exists() {
            let log = std::fs::read_to_string(dir.join(format!("task-{i}.log")))
                .unwrap_or_else(|e| format!("(no log: {e})"));
            return Err(failed(format!(
                "task {i} wrote no {}:\n{log}",
                file.display()
            )));
        }
    }
    Ok(())
}

/// Merges the array's shards, runs the unsharded study and compares the two reports with the
/// study's own comparison (the numbers without timings and thread counts); the merged folder.
fn merge_and_compare(study: &Path, dir: &Path) -> Result<PathBuf, TaskError> {
    let path = |p: &Path| p.display().to_string();
    let merged = dir.join("merged");
    run(
        &path(study),
        &["merge", &path(&dir.join("array")), "--out", &path(&merged)],
        &[],
    )?;
    let single = dir.join("single");
    run(&path(study), &["--quick", "--out", &path(&single)], &[])?;
    let report = |d: &Path| path(&d.join("pendulum").join("report.json"));
    run(
        &path(study),
        &["compare", &report(&merged), &report(&single)],
        &[],
    )
    .map_err(|e| {
        failed(format!(
            "the merged report differs from the unsharded one: {e}"
        ))
    })?;
    Ok(merged)
}
