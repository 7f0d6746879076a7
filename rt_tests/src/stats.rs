//! Latency percentiles ([`runtime::executor::Stats`], HDR histograms of 1 ns .. 60 s with 3
//! significant digits) as markdown table rows, plus small formatting helpers.

pub use runtime::executor::Stats;

/// `(name, value ns)` of each table column of `p`, in table order.
pub fn columns(p: &Stats) -> [(&'static str, u64); 6] {
    [
        ("min", p.min),
        ("p50", p.p50),
        ("p90", p.p90),
        ("p99", p.p99),
        ("p99.9", p.p999),
        ("max", p.max),
    ]
}

/// Markdown table header for percentile rows (after `lead` column names).
pub fn table_header(lead: &[&str]) -> String {
    let mut s = String::from("|");
    for l in lead {
        s += &format!(" {l} |");
    }
    s += " n | min µs | p50 µs | p90 µs | p99 µs | p99.9 µs | max µs |\n|";
    for _ in 0..lead.len() + 7 {
        s += "---|";
    }
    s + "\n"
}

/// One markdown table row.
pub fn table_row(lead: &[String], p: &Stats) -> String {
    let mut s = String::from("|");
    for l in lead {
        s += &format!(" {l} |");
    }
    s += &format!(" {} |", p.count);
    for (_, v) in columns(p) {
        s += &format!(" {} |", us(v));
    }
    s + "\n"
}

/// ns as µs with one decimal.
pub fn us(ns: u64) -> String {
    format!("{:.1}", ns as f64 / 1e3)
}

/// `a / b` (NaN-free: `b == 0` gives infinity unless `a == 0`, then 1).
pub fn ratio(a: u64, b: u64) -> f64 {
    if b == 0 {
        if a == 0 { 1.0 } else { f64::INFINITY }
    } else {
        a as f64 / b as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_has_one_cell_per_header_column() {
        let p = Stats::of_samples(&[1000, 2000, 3000]);
        let head = table_header(&["case"]);
        let row = table_row(&["a".into()], &p);
        let cells = |l: &str| l.matches('|').count();
        assert_eq!(cells(head.lines().next().unwrap()), cells(&row));
        assert!(row.starts_with("| a | 3 | 1.0 | 2.0 |"), "{row}");
        assert_eq!(ratio(0, 0), 1.0);
        assert_eq!(ratio(3, 2), 1.5);
        assert_eq!(us(1250), "1.2");
    }
}
