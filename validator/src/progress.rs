//! A progress bar on stderr for long `ommcheck check` runs, shown only when
//! stderr is a terminal, so logs and pipes stay clean.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Scenes, or bytes of scene files, from which a run shows progress.
const LONG_RUN_SCENES: u64 = 4;
const LONG_RUN_BYTES: u64 = 64 << 20;

/// Progress over `scenes` scenes whose files hold `bytes`; hidden
/// for short runs and when stderr is not a terminal.
pub fn for_scenes(scenes: u64, bytes: u64) -> ProgressBar {
    if scenes < LONG_RUN_SCENES && bytes < LONG_RUN_BYTES {
        return ProgressBar::hidden();
    }
    // `stderr()` draws nothing when stderr is not a terminal.
    let bar = ProgressBar::with_draw_target(Some(scenes), ProgressDrawTarget::stderr());
    if let Ok(style) =
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} scenes {wide_msg}")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_prefix("checking");
    bar
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_runs_and_pipes_show_nothing() {
        use std::io::IsTerminal;
        assert!(for_scenes(1, 0).is_hidden());
        let terminal = std::io::stderr().is_terminal();
        assert_eq!(for_scenes(100, 0).is_hidden(), !terminal);
        assert_eq!(for_scenes(1, 1 << 30).is_hidden(), !terminal);
    }
}
