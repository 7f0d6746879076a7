//! Percentiles of latency samples (HDR histograms, 1 ns .. 60 s, 3 significant digits).

use hdrhistogram::Histogram;
use serde::Serialize;

/// A latency histogram.
pub fn histogram() -> Histogram<u64> {
    Histogram::new_with_bounds(1, 60_000_000_000, 3).expect("constant bounds are valid")
}

/// min, p50, p90, p99, p99.9, max (ns) of one measurement.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Percentiles {
    /// Samples.
    pub count: u64,
    /// Smallest, ns.
    pub min: u64,
    /// Mean, ns.
    pub mean: f64,
    /// Median, ns.
    pub p50: u64,
    /// 90th percentile, ns.
    pub p90: u64,
    /// 99th percentile, ns.
    pub p99: u64,
    /// 99.9th percentile, ns.
    pub p999: u64,
    /// Largest, ns.
    pub max: u64,
}

impl Percentiles {
    /// Of a histogram (all zero if empty).
    pub fn of(h: &Histogram<u64>) -> Self {
        if h.is_empty() {
            return Self::default();
        }
        Self {
            count: h.len(),
            min: h.min(),
            mean: h.mean(),
            p50: h.value_at_quantile(0.5),
            p90: h.value_at_quantile(0.9),
            p99: h.value_at_quantile(0.99),
            p999: h.value_at_quantile(0.999),
            max: h.max(),
        }
    }

    /// Of raw samples, ns.
    pub fn of_samples(samples: &[u64]) -> Self {
        let mut h = histogram();
        for &s in samples {
            h.saturating_record(s.max(1));
        }
        Self::of(&h)
    }

    /// `(name, value ns)` of each column, in table order.
    pub fn columns(&self) -> [(&'static str, u64); 6] {
        [
            ("min", self.min),
            ("p50", self.p50),
            ("p90", self.p90),
            ("p99", self.p99),
            ("p99.9", self.p999),
            ("max", self.max),
        ]
    }
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
pub fn table_row(lead: &[String], p: &Percentiles) -> String {
    let mut s = String::from("|");
    for l in lead {
        s += &format!(" {l} |");
    }
    s += &format!(" {} |", p.count);
    for (_, v) in p.columns() {
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
    fn percentiles_of_one_to_thousand() {
        let samples: Vec<u64> = (1..=1000).map(|k| k * 1000).collect();
        let p = Percentiles::of_samples(&samples);
        assert_eq!(p.count, 1000);
        assert_eq!(p.min, 1000);
        // 3 significant digits: values are exact to within 0.1%.
        for (got, want) in [(p.p50, 500_000), (p.p90, 900_000), (p.p99, 990_000)] {
            assert!(
                (got as f64 - want as f64).abs() <= want as f64 * 1e-3,
                "{got} {want}"
            );
        }
        assert!((p.max as f64 - 1e6).abs() <= 1e3);
        assert_eq!(ratio(0, 0), 1.0);
        assert_eq!(ratio(3, 2), 1.5);
        assert_eq!(us(1250), "1.2");
    }
}
