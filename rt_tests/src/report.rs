//! Output of a run: `report.md`, `report.json`, PNG histograms and `samples.mcap` (one JSON
//! channel per measurement, one record per sample) in the output directory.

use anyhow::{Context, Result};
use mcap::records::MessageHeader;
use plotters::prelude::*;
use plotters::style::FontStyle;
use serde::Serialize;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

const FONT_BYTES: &[u8] = include_bytes!("../../nodes/eval/assets/DejaVuSans.ttf");
const FONT: &str = "sans-serif";

/// A budget compared with a measured value.
#[derive(Debug, Clone, Serialize)]
pub struct BudgetCheck {
    /// Budget key (`budgets.<name>`) and what it applied to.
    pub name: String,
    /// The limit.
    pub limit: f64,
    /// The measured value (same unit).
    pub measured: f64,
    /// Unit.
    pub unit: &'static str,
    /// `measured <= limit`.
    pub ok: bool,
}

impl BudgetCheck {
    /// A check that passes when `measured <= limit`.
    pub fn at_most(name: impl Into<String>, measured: f64, limit: f64, unit: &'static str) -> Self {
        Self {
            name: name.into(),
            limit,
            measured,
            unit,
            ok: measured <= limit,
        }
    }
}

/// Markdown section listing budget checks.
pub fn budgets_markdown(checks: &[BudgetCheck]) -> String {
    let mut s = String::from(
        "\n## Budgets\n\n| budget | measured | limit | verdict |\n|---|---|---|---|\n",
    );
    for c in checks {
        s += &format!(
            "| {} | {:.3} {} | {:.3} {} | {} |\n",
            c.name,
            c.measured,
            c.unit,
            c.limit,
            c.unit,
            if c.ok { "ok" } else { "**VIOLATED**" }
        );
    }
    s
}

/// Per-sample records written to `samples.mcap`.
pub struct SampleLog {
    path: PathBuf,
    writer: mcap::Writer<BufWriter<File>>,
    schema: u16,
    channels: HashMap<String, (u16, u32)>,
}

impl std::fmt::Debug for SampleLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SampleLog")
            .field("path", &self.path)
            .finish()
    }
}

impl SampleLog {
    /// Create `dir/samples.mcap`.
    pub fn create(dir: &Path) -> Result<Self> {
        let path = dir.join("samples.mcap");
        let file = File::create(&path).with_context(|| format!("create {}", path.display()))?;
        let opts = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .profile("vpsom-rt-tests");
        let mut writer = opts
            .create(BufWriter::new(file))
            .with_context(|| format!("write {}", path.display()))?;
        let schema = writer.add_schema(
            "vpsom_rt_tests.Sample",
            "jsonschema",
            br#"{"type":"object","description":"one raw sample; times in ns"}"#,
        )?;
        Ok(Self {
            path,
            writer,
            schema,
            channels: HashMap::new(),
        })
    }

    /// Append one record on `topic` at `time_ns`.
    pub fn record<T: Serialize>(&mut self, topic: &str, time_ns: u64, value: &T) -> Result<()> {
        let entry = match self.channels.get_mut(topic) {
            Some(e) => e,
            None => {
                let id = self
                    .writer
                    .add_channel(self.schema, topic, "json", &BTreeMap::new())?;
                self.channels.entry(topic.to_string()).or_insert((id, 0))
            }
        };
        entry.1 += 1;
        let data = serde_json::to_vec(value)?;
        self.writer.write_to_known_channel(
            &MessageHeader {
                channel_id: entry.0,
                sequence: entry.1,
                log_time: time_ns,
                publish_time: time_ns,
            },
            &data,
        )?;
        Ok(())
    }

    /// Write the summary and close the file.
    pub fn finish(mut self) -> Result<PathBuf> {
        self.writer
            .finish()
            .with_context(|| format!("finish {}", self.path.display()))?;
        Ok(self.path)
    }
}

/// Write `report.md` and `report.json`.
pub fn write_reports<T: Serialize>(dir: &Path, markdown: &str, json: &T) -> Result<()> {
    std::fs::write(dir.join("report.md"), markdown)
        .with_context(|| format!("write {}", dir.join("report.md").display()))?;
    let text = serde_json::to_string_pretty(json)?;
    std::fs::write(dir.join("report.json"), text + "\n")
        .with_context(|| format!("write {}", dir.join("report.json").display()))?;
    Ok(())
}

fn ensure_font() -> Result<()> {
    static OK: OnceLock<bool> = OnceLock::new();
    if *OK
        .get_or_init(|| plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok())
    {
        Ok(())
    } else {
        anyhow::bail!("the bundled DejaVu Sans font could not be parsed")
    }
}

/// One series of a histogram plot: label and samples in ns.
#[derive(Debug)]
pub struct Series<'a> {
    /// Legend text.
    pub label: String,
    /// Samples, ns.
    pub samples: &'a [u64],
}

/// Draw a latency histogram (µs on x, log count on y) of `series` to `path`. Bins are shared:
/// 120 equal bins from 0 to the largest p99.9 × 1.5 (samples above fall in the last bin).
pub fn histogram_png(path: &Path, title: &str, series: &[Series<'_>]) -> Result<()> {
    ensure_font()?;
    const BINS: usize = 120;
    let mut hi_ns = 1000u64;
    for s in series {
        let p = crate::stats::Stats::of_samples(s.samples);
        hi_ns = hi_ns.max((p.p999 as f64 * 1.5) as u64);
    }
    let width = hi_ns as f64 / BINS as f64;
    let counts: Vec<Vec<u64>> = series
        .iter()
        .map(|s| {
            let mut c = vec![0u64; BINS];
            for &v in s.samples {
                c[((v as f64 / width) as usize).min(BINS - 1)] += 1;
            }
            c
        })
        .collect();
    let ymax = counts.iter().flatten().copied().max().unwrap_or(1).max(1) as f64;
    let root = BitMapBackend::new(path, (900, 500)).into_drawing_area();
    let e = |e: &dyn std::fmt::Display| anyhow::anyhow!("plot {}: {e}", path.display());
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, (FONT, 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..hi_ns as f64 / 1e3, (0.5f64..ymax * 2.0).log_scale())
        .map_err(|x| e(&x))?;
    chart
        .configure_mesh()
        .x_desc("latency, µs (last bin: ≥ its lower edge)")
        .y_desc("samples")
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14))
        .draw()
        .map_err(|x| e(&x))?;
    let colors = [BLUE, RED, GREEN, MAGENTA, CYAN, BLACK];
    for (k, (s, c)) in series.iter().zip(&counts).enumerate() {
        let color = colors[k % colors.len()];
        let pts: Vec<(f64, f64)> = c
            .iter()
            .enumerate()
            .flat_map(|(b, &n)| {
                let y = (n as f64).max(0.5);
                let x0 = b as f64 * width / 1e3;
                [(x0, y), (x0 + width / 1e3, y)]
            })
            .collect();
        chart
            .draw_series(LineSeries::new(pts, color.stroke_width(2)))
            .map_err(|x| e(&x))?
            .label(s.label.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color));
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 13))
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|x| e(&x))?;
    root.present().map_err(|x| e(&x))?;
    Ok(())
}
