//! `cargo xtask docs-check`: the pages of `docs/` stay pages.
//!
//! Each page has a limit in lines: the pages that figures and findings tend to grow have their
//! own ([`LIMITS`]), every other page the default ([`DEFAULT_LIMIT`]). A page over its limit
//! fails the check (exit code 1) with its length and limit; a limit naming a page that does not
//! exist fails it too, so that the list follows renames.

use std::fmt;
use std::path::Path;

use crate::{TaskError, workspace_root};

/// Pages with a limit of their own, in lines (`docs/<name>`).
pub const LIMITS: &[(&str, usize)] = &[("performance.md", 200), ("stability.md", 300)];

/// The limit of every other page of `docs/`, in lines.
pub const DEFAULT_LIMIT: usize = 600;

/// A page over its limit.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TooLong {
    /// The page's file name in `docs/`.
    pub page: String,
    /// Its length in lines.
    pub lines: usize,
    /// Its limit in lines.
    pub limit: usize,
}

impl fmt::Display for TooLong {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "docs/{}: {} lines, {} over its limit of {} (xtask/src/docs.rs)",
            self.page,
            self.lines,
            self.lines - self.limit,
            self.limit
        )
    }
}

/// The limit of page `name`.
pub fn limit_of(name: &str) -> usize {
    LIMITS
        .iter()
        .find(|(page, _)| *page == name)
        .map_or(DEFAULT_LIMIT, |&(_, limit)| limit)
}

/// The pages of `pages` (name, length in lines) that are over their limits, in the given order.
pub fn over_limits(pages: &[(String, usize)]) -> Vec<TooLong> {
    pages
        .iter()
        .filter_map(|(page, lines)| {
            let limit = limit_of(page);
            (*lines > limit).then(|| TooLong {
                page: page.clone(),
                lines: *lines,
                limit,
            })
        })
        .collect()
}

/// The Markdown pages of `dir` (file name, length in lines), by name.
pub fn page_lengths(dir: &Path) -> Result<Vec<(String, usize)>, TaskError> {
    let unreadable = |what: &Path, e: std::io::Error| {
        TaskError::Failed(format!("cannot read {}: {e}", what.display()))
    };
    let mut pages = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| unreadable(dir, e))? {
        let path = entry.map_err(|e| unreadable(dir, e))?.path();
        if path.extension().is_none_or(|ext| ext != "md") {
            continue;
        }
        let text = std::fs::read_to_string(&path).map_err(|e| unreadable(&path, e))?;
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
        pages.push((name.unwrap_or_default(), text.lines().count()));
    }
    pages.sort();
    Ok(pages)
}

/// Checks the pages of `dir`: `Err` naming every page over its limit and every limit whose
/// page is missing.
pub fn check(dir: &Path) -> Result<(), TaskError> {
    let pages = page_lengths(dir)?;
    let mut problems: Vec<String> = over_limits(&pages).iter().map(|t| t.to_string()).collect();
    for (page, _) in LIMITS {
        if !pages.iter().any(|(name, _)| name == page) {
            problems.push(format!(
                "docs/{page} has a limit (xtask/src/docs.rs) but no page"
            ));
        }
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(TaskError::Failed(problems.join("\n")))
    }
}

/// Runs the check on the workspace's `docs/`; takes no options.
pub fn run(args: &[String]) -> Result<(), TaskError> {
    if let Some(extra) = args.first() {
        return Err(TaskError::Usage(format!(
            "docs-check takes no options, found `{extra}`"
        )));
    }
    let dir = workspace_root()?.join("docs");
    check(&dir)?;
    println!("docs/: every page within its limit");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh folder of pages `(name, lines)` under the temporary directory.
    fn folder(tag: &str, pages: &[(&str, usize)]) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("xtask-docs-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for (name, lines) in pages {
            std::fs::write(dir.join(name), "a line\n".repeat(*lines)).unwrap();
        }
        dir
    }

    #[test]
    fn a_page_one_line_over_its_limit_fails_and_at_its_limit_passes() {
        let at = folder(
            "at",
            &[
                ("performance.md", 200),
                ("stability.md", 300),
                ("other.md", 600),
            ],
        );
        assert!(check(&at).is_ok());
        let over = folder(
            "over",
            &[
                ("performance.md", 201),
                ("stability.md", 300),
                ("other.md", 601),
            ],
        );
        let Err(TaskError::Failed(message)) = check(&over) else {
            panic!("an over-long page passed");
        };
        assert!(
            message.contains("docs/performance.md: 201 lines, 1 over its limit of 200"),
            "{message}"
        );
        assert!(message.contains("docs/other.md: 601 lines, 1 over its limit of 600"));
        assert!(!message.contains("stability.md"), "{message}");
        for dir in [at, over] {
            std::fs::remove_dir_all(dir).unwrap();
        }
    }

    #[test]
    fn a_limit_without_its_page_fails_and_other_files_are_not_pages() {
        let dir = folder("missing", &[("performance.md", 10), ("notes.txt", 9000)]);
        let Err(TaskError::Failed(message)) = check(&dir) else {
            panic!("a missing page passed");
        };
        assert_eq!(
            message,
            "docs/stability.md has a limit (xtask/src/docs.rs) but no page"
        );
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn limits_are_looked_up_by_name() {
        assert_eq!(limit_of("performance.md"), 200);
        assert_eq!(limit_of("stability.md"), 300);
        assert_eq!(limit_of("scenes.md"), DEFAULT_LIMIT);
        let pages = [("stability.md".to_string(), 301)];
        assert_eq!(
            over_limits(&pages),
            [TooLong {
                page: "stability.md".into(),
                lines: 301,
                limit: 300
            }]
        );
    }

    #[test]
    fn options_are_refused() {
        assert!(matches!(
            run(&["--fix".to_string()]),
            Err(TaskError::Usage(_))
        ));
    }
}
