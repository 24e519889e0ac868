//! The record of fuzzing that accumulates: every run whose inputs were
//! merged into the kept corpus (`cargo xtask fuzz --minutes N`, or
//! `--minimize`) appends one row per target to [`RECORD`], and the table of
//! cumulative executions per target in docs/hostile-input.md is rendered
//! from it, so "at least 10^7 executions per target" is a sum anyone can
//! redo from the file. The smoke runs of `cargo xtask test` are not
//! recorded: a test run must change no tracked file.

use std::fmt::Write as _;
use std::path::Path;

use crate::Error;

/// The record, relative to the workspace root: tab-separated, one row per
/// target and run, `#` lines are comments.
pub const RECORD: &str = "fuzz/executions.tsv";

/// The document holding the rendered table, between [`BEGIN`] and [`END`].
pub const DOC: &str = "docs/hostile-input.md";
const BEGIN: &str = "<!-- fuzz-executions:begin (cargo xtask fuzz --minutes N writes this table from fuzz/executions.tsv) -->";
const END: &str = "<!-- fuzz-executions:end -->";

const HEADER: &str =
    "# date\ttarget\texecutions\tseconds\tjobs\tcores\tcorpus_inputs\tcorpus_bytes\n";

/// One target's run.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// UTC, `YYYY-MM-DD`.
    pub date: String,
    pub target: String,
    /// Inputs executed, over all workers.
    pub executions: u64,
    /// Wall-clock seconds of fuzzing (each worker ran that long).
    pub seconds: u64,
    /// Workers run side by side.
    pub jobs: u64,
    /// Cores of the machine it ran on.
    pub cores: u64,
    /// The kept corpus after the merge (None in rows from before the record
    /// kept it).
    pub corpus: Option<(u64, u64)>,
}

impl Row {
    fn to_line(&self) -> String {
        let (inputs, bytes) = match self.corpus {
            Some((i, b)) => (i.to_string(), b.to_string()),
            None => ("-".into(), "-".into()),
        };
        format!(
            "{}\t{}\t{}\t{}\t{}\t{}\t{inputs}\t{bytes}\n",
            self.date, self.target, self.executions, self.seconds, self.jobs, self.cores
        )
    }

    fn parse(line: &str) -> Option<Row> {
        let f: Vec<&str> = line.split('\t').collect();
        let [date, target, executions, seconds, jobs, cores, inputs, bytes] = f[..] else {
            return None;
        };
        Some(Row {
            date: date.into(),
            target: target.into(),
            executions: executions.parse().ok()?,
            seconds: seconds.parse().ok()?,
            jobs: jobs.parse().ok()?,
            cores: cores.parse().ok()?,
            corpus: inputs.parse().ok().zip(bytes.parse().ok()),
        })
    }
}

/// Today's date, UTC, as `YYYY-MM-DD` (Howard Hinnant's civil-from-days;
/// xtask has no date crate and needs nothing more).
pub fn today() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    civil_date(secs / 86_400)
}

fn civil_date(days_since_epoch: u64) -> String {
    let z = days_since_epoch as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}")
}

/// Every row of the record (none where it does not exist yet).
pub fn read(root: &Path) -> Result<Vec<Row>, Error> {
    let path = root.join(RECORD);
    if !path.exists() {
        return Ok(Vec::new());
    }
    let text = crate::read(&path)?;
    text.lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| {
            Row::parse(l).ok_or_else(|| {
                Error::Tool(format!("{}: cannot read the row {l:?}", path.display()))
            })
        })
        .collect()
}

/// Appends `row` (writing the header first into a new record).
pub fn append(root: &Path, row: &Row) -> Result<(), Error> {
    use std::io::Write as _;
    let path = root.join(RECORD);
    let new = !path.exists();
    let io = |source| Error::Io {
        path: path.clone(),
        source,
    };
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .map_err(io)?;
    if new {
        file.write_all(HEADER.as_bytes()).map_err(io)?;
    }
    file.write_all(row.to_line().as_bytes()).map_err(io)
}

/// What the record adds up to for one target.
#[derive(Debug, PartialEq)]
pub struct Total {
    pub target: String,
    pub executions: u64,
    /// Seconds times workers: the core time spent.
    pub worker_seconds: u64,
    pub runs: usize,
    pub last_date: String,
    /// The corpus after the latest run that noted it.
    pub corpus: Option<(u64, u64)>,
}

/// The totals per target, in the order of `targets` (a target the record
/// lacks has none).
pub fn totals(rows: &[Row], targets: &[&str]) -> Vec<Total> {
    targets
        .iter()
        .filter_map(|&target| {
            let mine: Vec<&Row> = rows.iter().filter(|r| r.target == target).collect();
            let last = mine.last()?;
            Some(Total {
                target: target.into(),
                executions: mine.iter().map(|r| r.executions).sum(),
                worker_seconds: mine.iter().map(|r| r.seconds * r.jobs).sum(),
                runs: mine.len(),
                last_date: last.date.clone(),
                corpus: mine.iter().rev().find_map(|r| r.corpus),
            })
        })
        .collect()
}

/// `1234567` as `1,234,567`.
fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (k, c) in digits.chars().enumerate() {
        if k > 0 && (digits.len() - k).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// The markdown table of `totals`.
pub fn render(totals: &[Total]) -> String {
    let mut out = String::from(
        "| target | executions, cumulative | of 10^7 | runs | worker-hours | last run | kept corpus |\n\
         | --- | ---: | ---: | ---: | ---: | --- | ---: |\n",
    );
    for t in totals {
        let corpus = t.corpus.map_or("—".into(), |(inputs, bytes)| {
            format!("{} inputs, {} KB", grouped(inputs), bytes.div_ceil(1000))
        });
        let _ = writeln!(
            out,
            "| `{}` | {} | {:.1}% | {} | {:.2} | {} | {corpus} |",
            t.target,
            grouped(t.executions),
            t.executions as f64 / 1e5,
            t.runs,
            t.worker_seconds as f64 / 3600.0,
            t.last_date,
        );
    }
    out
}

/// Writes the table of `totals` between the markers of [`DOC`].
pub fn update_doc(root: &Path, totals: &[Total]) -> Result<(), Error> {
    let path = root.join(DOC);
    let text = crate::read(&path)?;
    let (Some(begin), Some(end)) = (text.find(BEGIN), text.find(END)) else {
        return Err(Error::Tool(format!(
            "{}: lacks the markers {BEGIN} and {END}",
            path.display()
        )));
    };
    let updated = format!(
        "{}{BEGIN}\n{}{}",
        &text[..begin],
        render(totals),
        &text[end..]
    );
    std::fs::write(&path, updated).map_err(|source| Error::Io { path, source })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates() {
        assert_eq!(civil_date(0), "1970-01-01");
        // 2026-11-29 is day 20,786 of the Unix epoch.
        assert_eq!(civil_date(20_786), "2026-11-29");
        assert_eq!(civil_date(11_016), "2000-02-29");
    }

    #[test]
    fn rows_read_back_and_add_up_per_target() {
        let rows: Vec<Row> = [
            "2026-11-24\tdecode\t359338\t601\t1\t2\t-\t-\n",
            "2026-11-29\tdecode\t1000\t60\t16\t16\t95\t8458\n",
            "2026-11-29\tscene\t5\t1\t1\t2\t3\t4\n",
        ]
        .iter()
        .map(|l| Row::parse(l.trim_end()).unwrap())
        .collect();
        assert_eq!(
            rows[1].to_line(),
            "2026-11-29\tdecode\t1000\t60\t16\t16\t95\t8458\n"
        );
        let totals = totals(&rows, &["raw_reader", "decode"]);
        assert_eq!(
            totals,
            [Total {
                target: "decode".into(),
                executions: 360_338,
                worker_seconds: 601 + 960,
                runs: 2,
                last_date: "2026-11-29".into(),
                corpus: Some((95, 8458)),
            }]
        );
        assert!(render(&totals)
            .contains("| `decode` | 360,338 | 3.6% | 2 | 0.43 | 2026-11-29 | 95 inputs, 9 KB |"));
    }
}
