//! `--shard I/N` or `--shard auto` (from a Slurm job array).

/// The shard asked for on the command line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ShardArg {
    /// Paths i with i % count == index.
    Fixed {
        /// I.
        index: usize,
        /// N.
        count: usize,
    },
    /// From the Slurm job array the process runs in.
    Auto,
}

impl ShardArg {
    /// Reads `I/N` (0 <= I < N) or `auto`.
    pub fn parse(value: &str) -> Result<ShardArg, String> {
        if value == "auto" {
            return Ok(ShardArg::Auto);
        }
        let bad = || format!("expected I/N with 0 <= I < N, or auto; got '{value}'");
        let (i, n) = value.split_once('/').ok_or_else(bad)?;
        let (index, count): (usize, usize) =
            (i.parse().map_err(|_| bad())?, n.parse().map_err(|_| bad())?);
        if index < count {
            Ok(ShardArg::Fixed { index, count })
        } else {
            Err(bad())
        }
    }

    /// (I, N), with `auto` read through `var` (the environment in the program): I is the
    /// task's place in the array, (SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN) /
    /// SLURM_ARRAY_TASK_STEP (MIN 0 and STEP 1 when unset), and N is SLURM_ARRAY_TASK_COUNT.
    pub fn resolve(self, var: impl Fn(&str) -> Option<String>) -> Result<(usize, usize), String> {
        let (index, count) = match self {
            ShardArg::Fixed { index, count } => return Ok((index, count)),
            ShardArg::Auto => ("SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_COUNT"),
        };
        let read = |name: &str, default: Option<usize>| -> Result<usize, String> {
            match (var(name), default) {
                (Some(text), _) => text
                    .trim()
                    .parse()
                    .map_err(|_| format!("--shard auto: {name} = '{text}' is not a number")),
                (None, Some(d)) => Ok(d),
                (None, None) => Err(format!(
                    "--shard auto needs {index} and {count} (set by a Slurm job array, \
                     `sbatch --array=0-N`); {name} is not set"
                )),
            }
        };
        let (id, total) = (read(index, None)?, read(count, None)?);
        let min = read("SLURM_ARRAY_TASK_MIN", Some(0))?;
        let step = read("SLURM_ARRAY_TASK_STEP", Some(1))?.max(1);
        let place = id
            .checked_sub(min)
            .map(|d| d / step)
            .filter(|&place| place < total)
            .ok_or_else(|| {
                format!(
                    "--shard auto: {index} = {id} is not in an array of {total} tasks from {min}"
                )
            })?;
        Ok((place, total))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(pairs: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| {
            pairs
                .iter()
                .find(|(k, _)| *k == name)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn fixed_shards_are_read_and_checked() {
        assert_eq!(
            ShardArg::parse("1/4"),
            Ok(ShardArg::Fixed { index: 1, count: 4 })
        );
        assert!(ShardArg::parse("4/4").is_err());
        assert!(ShardArg::parse("1").is_err());
        assert_eq!(ShardArg::parse("auto"), Ok(ShardArg::Auto));
    }

    #[test]
    fn auto_reads_the_slurm_array() {
        let vars = [
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ];
        assert_eq!(ShardArg::Auto.resolve(env(&vars)), Ok((2, 4)));
        // --array=1-4 and --array=10-16:2 number tasks from MIN in STEPs.
        let vars = [
            ("SLURM_ARRAY_TASK_ID", "4"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
        ];
        assert_eq!(ShardArg::Auto.resolve(env(&vars)), Ok((3, 4)));
        let vars = [
            ("SLURM_ARRAY_TASK_ID", "14"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
            ("SLURM_ARRAY_TASK_MIN", "10"),
            ("SLURM_ARRAY_TASK_STEP", "2"),
        ];
        assert_eq!(ShardArg::Auto.resolve(env(&vars)), Ok((2, 4)));
    }

    #[test]
    fn auto_outside_an_array_names_both_variables() {
        let err = ShardArg::Auto.resolve(env(&[])).unwrap_err();
        assert!(err.contains("SLURM_ARRAY_TASK_ID"), "{err}");
        assert!(err.contains("SLURM_ARRAY_TASK_COUNT"), "{err}");
        let vars = [
            ("SLURM_ARRAY_TASK_ID", "x"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ];
        assert!(ShardArg::Auto.resolve(env(&vars)).is_err());
        let vars = [
            ("SLURM_ARRAY_TASK_ID", "9"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ];
        assert!(ShardArg::Auto.resolve(env(&vars)).is_err());
    }
}
