//! Numbers in the paper's prose, read from `results/`.
//!
//! A number the paper quotes is written between two markers that say where
//! it comes from:
//!
//! ```text
//! ends at <!-- value 06-6/data.csv case=sl-gridless-reflect final_retained %1 -->104.9 %<!-- /value -->
//! ```
//!
//! `smokelab paper` replaces the text between the markers with the value
//! read now: the CSV file under `results/`, any number of `column=value`
//! filters choosing rows (a value with spaces in double quotes), the column (prefixed `max:` or `min:` for the
//! largest or smallest over the chosen rows, else exactly one row must
//! match), and the format: `%N` a percentage with N decimals, `fN` N
//! decimals, `xN` a factor (`1.9×`), `eN` `m × 10ⁿ` with N decimals in
//! `m`. Two such cells joined by a lone `/` give their ratio
//! (`a/costs.csv kind=value ms / a/costs.csv kind=fast ms x1`). So a regenerated result
//! changes the prose with it, and the paper test catches a stale paper.

use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};

const OPEN: &str = "<!-- value ";
const CLOSE: &str = "<!-- /value -->";

/// `doc` with every value marker's text replaced by the value it names.
///
/// # Errors
/// A malformed marker, a missing file or column, no or several matching
/// rows, or a cell that is not a number.
pub fn fill(doc: &str, results: &Path) -> Result<String> {
    let mut out = String::with_capacity(doc.len());
    let mut rest = doc;
    while let Some(at) = rest.find(OPEN) {
        out.push_str(&rest[..at]);
        let marker = &rest[at..];
        let head_end = marker
            .find(" -->")
            .ok_or_else(|| anyhow!("unclosed value marker: {}", first_line(marker)))?;
        let spec = &marker[OPEN.len()..head_end];
        let body = &marker[head_end + 4..];
        let close = body
            .find(CLOSE)
            .ok_or_else(|| anyhow!("value marker without {CLOSE}: {spec}"))?;
        let value = read(spec, results).with_context(|| format!("paper value `{spec}`"))?;
        out.push_str(&marker[..head_end + 4]);
        out.push_str(&value);
        out.push_str(CLOSE);
        rest = &body[close + CLOSE.len()..];
    }
    out.push_str(rest);
    Ok(out)
}

fn first_line(s: &str) -> &str {
    s.lines().next().unwrap_or("")
}

/// The words of a marker's `spec`: split at spaces outside double quotes,
/// the quotes removed (`panel="fixed step cell"`).
fn words(spec: &str) -> Vec<String> {
    let (mut words, mut word, mut quoted) = (Vec::new(), String::new(), false);
    for c in spec.chars() {
        match c {
            '"' => quoted = !quoted,
            c if c.is_whitespace() && !quoted => {
                if !word.is_empty() {
                    words.push(std::mem::take(&mut word));
                }
            }
            c => word.push(c),
        }
    }
    if !word.is_empty() {
        words.push(word);
    }
    words
}

/// The formatted value a marker's `spec` names: one cell
/// (`FILE [COLUMN=VALUE …] COLUMN FORMAT`) or the ratio of two
/// (`FILE … COLUMN / FILE … COLUMN FORMAT`).
fn read(spec: &str, results: &Path) -> Result<String> {
    let words = words(spec);
    let words: Vec<&str> = words.iter().map(String::as_str).collect();
    let Some((format, cells)) = words.split_last() else {
        bail!("expected `FILE [COLUMN=VALUE …] COLUMN FORMAT`");
    };
    let value = match cells.iter().position(|w| *w == "/") {
        Some(slash) => cell(&cells[..slash], results)? / cell(&cells[slash + 1..], results)?,
        None => cell(cells, results)?,
    };
    format_value(value, format)
}

/// The number `FILE [COLUMN=VALUE …] [max:|min:]COLUMN` names.
fn cell(words: &[&str], results: &Path) -> Result<f64> {
    let [file, filters @ .., column] = words else {
        bail!("expected `FILE [COLUMN=VALUE …] COLUMN` in {words:?}");
    };
    let path = results.join(file);
    let mut reader =
        csv::Reader::from_path(&path).with_context(|| format!("cannot read {}", path.display()))?;
    let header = reader.headers()?.clone();
    let index = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| anyhow!("{file} has no column {name}"))
    };
    let (aggregate, column) = match column.split_once(':') {
        Some((a @ ("max" | "min"), c)) => (Some(a), c),
        _ => (None, *column),
    };
    let col = index(column)?;
    let mut wanted = Vec::new();
    for f in filters {
        let (k, v) = f
            .split_once('=')
            .ok_or_else(|| anyhow!("filter {f} is not COLUMN=VALUE"))?;
        wanted.push((index(k)?, v));
    }
    let mut values = Vec::new();
    for row in reader.records() {
        let row = row?;
        if wanted.iter().all(|(i, v)| row.get(*i) == Some(*v)) {
            let cell = row.get(col).unwrap_or("");
            let x: f64 = cell
                .parse()
                .map_err(|_| anyhow!("{file}: {column} = {cell:?} is not a number"))?;
            values.push(x);
        }
    }
    Ok(match (aggregate, values.as_slice()) {
        (_, []) => bail!("no row of {file} matches {filters:?}"),
        (Some("max"), v) => v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        (Some(_), v) => v.iter().copied().fold(f64::INFINITY, f64::min),
        (None, [x]) => *x,
        (None, v) => bail!("{} rows of {file} match {filters:?}; add a filter", v.len()),
    })
}

/// `value` in the marker's format (`%N`, `fN`, `eN`, `xN`).
fn format_value(value: f64, format: &str) -> Result<String> {
    let (kind, digits) = format.split_at(1);
    let digits: usize = digits
        .parse()
        .map_err(|_| anyhow!("format {format} is not %N, fN, eN or xN"))?;
    Ok(match kind {
        "%" => format!("{:.digits$} %", value * 100.0),
        "f" => format!("{value:.digits$}"),
        "x" => format!("{value:.digits$}×"),
        "e" if value == 0.0 => "0".into(),
        "e" => {
            let text = format!("{value:.digits$e}");
            let (mantissa, exponent) = text.split_once('e').unwrap_or((&text, "0"));
            let superscript: String = exponent
                .chars()
                .map(|c| match c {
                    '-' => '⁻',
                    d => "⁰¹²³⁴⁵⁶⁷⁸⁹"
                        .chars()
                        .nth(d.to_digit(10).unwrap_or(0) as usize)
                        .unwrap_or('⁰'),
                })
                .collect();
            format!("{mantissa} × 10{superscript}")
        }
        _ => bail!("format {format} is not %N, fN, eN or xN"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn results() -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("x")).unwrap();
        std::fs::write(
            dir.path().join("x/data.csv"),
            "case,retained,error\na,1.0493,4.6e-6\nb c,0.9948,3.1e-7\n",
        )
        .unwrap();
        dir
    }

    #[test]
    fn markers_are_refilled_from_the_csv() {
        let r = results();
        let doc = "ends at <!-- value x/data.csv case=a retained %1 -->71 %<!-- /value -->, \
                   error <!-- value x/data.csv max:error e1 -->?<!-- /value -->.";
        let out = fill(doc, r.path()).unwrap();
        assert_eq!(
            out,
            "ends at <!-- value x/data.csv case=a retained %1 -->104.9 %<!-- /value -->, \
             error <!-- value x/data.csv max:error e1 -->4.6 × 10⁻⁶<!-- /value -->."
        );
        let quoted = "<!-- value x/data.csv case=\"b c\" retained f2 -->x<!-- /value -->";
        assert!(fill(quoted, r.path()).unwrap().contains("-->0.99<!--"));
        let ratio = "<!-- value x/data.csv case=a retained / x/data.csv case=\"b c\" retained x2 -->?<!-- /value -->";
        assert!(fill(ratio, r.path()).unwrap().contains("-->1.05×<!--"));
        // Filling is idempotent.
        assert_eq!(fill(&out, r.path()).unwrap(), out);
    }

    #[test]
    fn bad_markers_name_what_is_wrong() {
        let r = results();
        let err = |doc: &str| format!("{:#}", fill(doc, r.path()).unwrap_err());
        assert!(err("<!-- value x/data.csv retained f2 -->1<!-- /value -->").contains("2 rows"));
        assert!(
            err("<!-- value x/data.csv case=a nope f2 -->1<!-- /value -->")
                .contains("no column nope")
        );
        assert!(
            err("<!-- value x/data.csv case=z retained f2 -->1<!-- /value -->").contains("no row")
        );
        assert!(
            err("<!-- value x/data.csv case=a retained q2 -->1<!-- /value -->")
                .contains("format q2")
        );
        assert!(err("<!-- value x/data.csv case=a retained f2 -->1").contains("without"));
    }
}
