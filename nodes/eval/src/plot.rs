//! Figure-10-style top-down figures: room, ground-truth cuboids (black outlines), estimated
//! cuboids (filled by class colour, labelled), the base trajectory, GBVs (red wedges) and LBVs
//! (small blue wedges), with a legend and the run's key metrics in the title.

use super::metrics::{EstObject, GtObject, Metrics, RunInfo};
use super::report::planner_title;
use super::{EvalError, PLOT_FILE, read_json};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The font shipped with the crate (DejaVu Sans; licence in `nodes/eval/assets/`).
const FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
/// Font family name under which it is registered.
const FONT: &str = "sans-serif";
/// Size of a run's figure `map.png`, pixels.
pub const RUN_FIGURE_SIZE: (u32, u32) = (1100, 820);

/// Axis-aligned room footprint, world frame, metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Room {
    /// Lower-left corner `[x, y]`.
    pub min: [f32; 2],
    /// Upper-right corner `[x, y]`.
    pub max: [f32; 2],
}

/// A chosen camera view: camera position, world yaw and pitch (positive = down).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ViewPose {
    /// Camera position, world frame, metres.
    pub position: [f32; 3],
    /// Camera yaw in the world, radians.
    pub yaw: f32,
    /// Camera pitch, radians.
    pub pitch: f32,
}

/// The key metrics shown in a figure's title.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Headline {
    /// Precision.
    pub precision: f64,
    /// Recall.
    pub recall: f64,
    /// IoU (null if undefined).
    pub iou: Option<f64>,
    /// CDE, metres (null if undefined).
    pub cde_m: Option<f64>,
    /// Path length, metres.
    pub path_length_m: f64,
    /// Simulated time, seconds.
    pub time_s: f64,
    /// Non-occlusion (null if undefined).
    pub non_occlusion: Option<f64>,
}

impl Headline {
    /// The headline of a run's metrics.
    pub fn of(m: &Metrics) -> Self {
        Self {
            precision: m.precision,
            recall: m.recall,
            iou: m.iou,
            cde_m: m.cde_m,
            path_length_m: m.path_length_m,
            time_s: m.time_s,
            non_occlusion: m.non_occlusion,
        }
    }

    fn text(&self) -> String {
        let opt = |v: Option<f64>, d: usize| v.map_or("–".to_string(), |v| format!("{v:.d$}"));
        format!(
            "P {:.2}   R {:.2}   IoU {}   CDE {} m   path {:.2} m   time {:.0} s   non-occl. {}",
            self.precision,
            self.recall,
            opt(self.iou, 3),
            opt(self.cde_m, 3),
            self.path_length_m,
            self.time_s,
            opt(self.non_occlusion, 3)
        )
    }
}

/// Everything a figure shows (also written as `plot.json` beside `metrics.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlotInput {
    /// Scene, planner, seed (title).
    pub run: RunInfo,
    /// Room footprint.
    pub room: Room,
    /// Ground-truth objects.
    pub gt: Vec<GtObject>,
    /// Estimated objects.
    pub estimated: Vec<EstObject>,
    /// True base trajectory `[x, y]`.
    pub trajectory: Vec<[f32; 2]>,
    /// Chosen global best views.
    pub gbv: Vec<ViewPose>,
    /// Chosen local best views (subsampled).
    pub lbv: Vec<ViewPose>,
    /// Key metrics for the title.
    pub headline: Option<Headline>,
}

impl PlotInput {
    /// LBVs kept for a figure.
    pub const MAX_LBV: usize = 150;
}

/// A figure rendered for the bench report.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// Scene.
    pub scene: String,
    /// Planner.
    pub planner: String,
    /// Seed of the run shown.
    pub seed: u64,
    /// File name inside the output directory.
    pub file_name: String,
    /// Full path.
    pub path: PathBuf,
}

fn ensure_font() -> Result<(), String> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err("the bundled DejaVu Sans font could not be parsed".into())
    }
}

/// Render a figure to a PNG file of `size` pixels (parent directories are created).
pub fn render_png(input: &PlotInput, path: &Path, size: (u32, u32)) -> Result<(), EvalError> {
    let fail = |reason: String| EvalError::Plot {
        path: path.to_path_buf(),
        reason,
    };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| EvalError::io(dir, e))?;
    }
    ensure_font().map_err(fail)?;
    let root = BitMapBackend::new(path, size).into_drawing_area();
    draw_figure(&root, input).map_err(fail)?;
    root.present().map_err(|e| fail(e.to_string()))
}

/// Render a figure into an RGB buffer (`3 · w · h` bytes, row-major).
pub fn render_rgb(input: &PlotInput, size: (u32, u32)) -> Result<Vec<u8>, EvalError> {
    let fail = |reason: String| EvalError::Plot {
        path: PathBuf::from("<memory>"),
        reason,
    };
    ensure_font().map_err(fail)?;
    let mut buf = vec![0u8; 3 * size.0 as usize * size.1 as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        draw_figure(&root, input).map_err(fail)?;
        root.present().map_err(|e| fail(e.to_string()))?;
    }
    Ok(buf)
}

/// For the bench report: one figure per (scene, planner), from the run with the lowest seed that
/// has a `plot.json` beside its `metrics.json`, written as `fig_<scene>_<planner>.png` into
/// `out_dir`; plus `figure10.png`, a grid of them (rows scenes, columns planners) like the
/// paper's Figure 10. Runs without `plot.json` are skipped.
pub fn render_bench_figures(
    metrics_files: &[PathBuf],
    out_dir: &Path,
) -> Result<Vec<Figure>, EvalError> {
    let mut chosen: BTreeMap<(String, String), PlotInput> = BTreeMap::new();
    for file in metrics_files {
        let Some(dir) = file.parent() else { continue };
        let plot_path = dir.join(PLOT_FILE);
        if !plot_path.is_file() {
            continue;
        }
        let input: PlotInput = read_json(&plot_path)?;
        let key = (input.run.scene.clone(), input.run.planner.clone());
        let keep = chosen.get(&key).is_none_or(|c| input.run.seed < c.run.seed);
        if keep {
            chosen.insert(key, input);
        }
    }
    let mut figures = Vec::new();
    for ((scene, planner), input) in &chosen {
        let file_name = format!("fig_{}_{}.png", file_safe(scene), file_safe(planner));
        let path = out_dir.join(&file_name);
        render_png(input, &path, RUN_FIGURE_SIZE)?;
        figures.push(Figure {
            scene: scene.clone(),
            planner: planner.clone(),
            seed: input.run.seed,
            file_name,
            path,
        });
    }
    if !chosen.is_empty() {
        render_grid(&chosen, &out_dir.join("figure10.png"))?;
    }
    Ok(figures)
}

fn render_grid(
    chosen: &BTreeMap<(String, String), PlotInput>,
    path: &Path,
) -> Result<(), EvalError> {
    let fail = |reason: String| EvalError::Plot {
        path: path.to_path_buf(),
        reason,
    };
    let mut scenes: Vec<&String> = chosen.keys().map(|k| &k.0).collect();
    scenes.dedup();
    let mut planners: Vec<&String> = chosen.keys().map(|k| &k.1).collect();
    planners.sort_by_key(|p| (super::report::paper_planner(p).unwrap_or(3), p.to_string()));
    planners.dedup();
    let (cw, ch) = (760u32, 600u32);
    let size = (cw * planners.len() as u32, ch * scenes.len() as u32);
    ensure_font().map_err(fail)?;
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(e.to_string()))?;
    let cells = root.split_evenly((scenes.len(), planners.len()));
    for (r, scene) in scenes.iter().enumerate() {
        for (c, planner) in planners.iter().enumerate() {
            let key = ((*scene).clone(), (*planner).clone());
            if let Some(input) = chosen.get(&key) {
                draw_figure(&cells[r * planners.len() + c], input).map_err(fail)?;
            }
        }
    }
    root.present().map_err(|e| fail(e.to_string()))
}

fn file_safe(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Distinct colours (Tableau 10 followed by darker variants).
const PALETTE: [RGBColor; 14] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(127, 127, 127),
    RGBColor(214, 39, 40),
    RGBColor(0, 90, 50),
    RGBColor(120, 60, 0),
    RGBColor(70, 40, 140),
    RGBColor(0, 110, 140),
];

const GBV_COLOR: RGBColor = RGBColor(220, 20, 20);
const LBV_COLOR: RGBColor = RGBColor(30, 70, 230);
const PATH_COLOR: RGBColor = RGBColor(20, 20, 20);
const FLOOR_COLOR: RGBColor = RGBColor(246, 246, 242);
/// Half of the camera's horizontal field of view (paper: 60°), radians.
const HALF_FOV: f32 = std::f32::consts::FRAC_PI_6;

/// Footprint corners of a cuboid (counter-clockwise).
fn footprint(center: [f32; 3], size: [f32; 3], yaw: f32) -> Vec<(f64, f64)> {
    let (s, c) = yaw.sin_cos();
    let (hx, hy) = (size[0] / 2.0, size[1] / 2.0);
    [(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)]
        .iter()
        .map(|(x, y)| {
            (
                f64::from(center[0] + c * x - s * y),
                f64::from(center[1] + s * x + c * y),
            )
        })
        .collect()
}

/// View wedge: apex at the camera, opening ±HALF_FOV around its yaw.
fn wedge(v: &ViewPose, length: f32) -> Vec<(f64, f64)> {
    let p = (f64::from(v.position[0]), f64::from(v.position[1]));
    let ray = |a: f32| {
        (
            p.0 + f64::from(length * a.cos()),
            p.1 + f64::from(length * a.sin()),
        )
    };
    vec![p, ray(v.yaw - HALF_FOV), ray(v.yaw + HALF_FOV)]
}

/// A darker shade of a colour, for text on the light floor.
fn darker(c: RGBColor) -> RGBColor {
    let f = |v: u8| (f32::from(v) * 0.7) as u8;
    RGBColor(f(c.0), f(c.1), f(c.2))
}

fn closed(mut pts: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    if let Some(first) = pts.first().copied() {
        pts.push(first);
    }
    pts
}

fn font(size: f64) -> TextStyle<'static> {
    TextStyle::from((FONT, size).into_font())
}

fn err<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// Draw one figure into `area`.
fn draw_figure<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    input: &PlotInput,
) -> Result<(), String> {
    area.fill(&WHITE).map_err(err)?;
    let (w, h) = area.dim_in_pixel();
    let title_h = 58u32.min(h / 4);
    let legend_w = 200u32.min(w / 3);
    let (top, body) = area.split_vertically(title_h);
    let (plot_area, legend_area) = body.split_horizontally(w - legend_w);

    // Title: scene / planner / seed and the key metrics.
    let run = &input.run;
    let title = format!(
        "{} — {} — seed {}",
        run.scene,
        planner_title(&run.planner),
        run.seed
    );
    top.draw(&Text::new(title, (12, 6), font(22.0).color(&BLACK)))
        .map_err(err)?;
    if let Some(hl) = &input.headline {
        top.draw(&Text::new(hl.text(), (12, 34), font(15.0).color(&BLACK)))
            .map_err(err)?;
    }

    // Class colours in order of first appearance among sorted class names.
    let mut classes: Vec<&str> = input
        .gt
        .iter()
        .map(|o| o.class.as_str())
        .chain(input.estimated.iter().map(|o| o.class.as_str()))
        .collect();
    classes.sort_unstable();
    classes.dedup();
    let colour = |class: &str| {
        let i = classes.iter().position(|c| *c == class).unwrap_or(0);
        PALETTE[i % PALETTE.len()]
    };

    // Equal-scale axes covering the room (and anything drawn outside it) with a margin.
    let mut lo = [input.room.min[0], input.room.min[1]];
    let mut hi = [input.room.max[0], input.room.max[1]];
    for p in input
        .trajectory
        .iter()
        .copied()
        .chain(input.gbv.iter().map(|v| [v.position[0], v.position[1]]))
    {
        lo = [lo[0].min(p[0]), lo[1].min(p[1])];
        hi = [hi[0].max(p[0]), hi[1].max(p[1])];
    }
    let margin = 0.35f64;
    let (x0, x1) = (f64::from(lo[0]) - margin, f64::from(hi[0]) + margin);
    let (y0, y1) = (f64::from(lo[1]) - margin, f64::from(hi[1]) + margin);
    let (pw, ph) = plot_area.dim_in_pixel();
    let (label_x, label_y, chart_margin) = (36u32, 48u32, 10u32);
    let px = f64::from(pw.saturating_sub(label_y + 2 * chart_margin).max(10));
    let py = f64::from(ph.saturating_sub(label_x + 2 * chart_margin).max(10));
    let scale = (px / (x1 - x0)).min(py / (y1 - y0));
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let (hw, hh) = (px / scale / 2.0, py / scale / 2.0);

    let mut chart = ChartBuilder::on(&plot_area)
        .margin(chart_margin)
        .x_label_area_size(label_x)
        .y_label_area_size(label_y)
        .build_cartesian_2d((cx - hw)..(cx + hw), (cy - hh)..(cy + hh))
        .map_err(err)?;
    chart
        .configure_mesh()
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(215, 215, 215))
        .label_style(font(13.0))
        .x_desc("x (m)")
        .y_desc("y (m)")
        .axis_desc_style(font(13.0))
        .draw()
        .map_err(err)?;

    // Room: floor and walls.
    let (rx0, ry0) = (f64::from(input.room.min[0]), f64::from(input.room.min[1]));
    let (rx1, ry1) = (f64::from(input.room.max[0]), f64::from(input.room.max[1]));
    chart
        .draw_series([
            Rectangle::new([(rx0, ry0), (rx1, ry1)], FLOOR_COLOR.filled()),
            Rectangle::new([(rx0, ry0), (rx1, ry1)], BLACK.stroke_width(3)),
        ])
        .map_err(err)?;

    // Estimated cuboids: background lightly, foreground strongly filled by class colour.
    for background in [true, false] {
        let alpha = if background { 0.18 } else { 0.55 };
        let objs = input
            .estimated
            .iter()
            .filter(|o| o.background == background);
        for o in objs.clone() {
            let c = colour(&o.class);
            let pts = footprint(o.center, o.size, o.yaw);
            chart
                .draw_series([Polygon::new(pts.clone(), c.mix(alpha).filled())])
                .map_err(err)?;
            chart
                .draw_series([PathElement::new(closed(pts), c.stroke_width(2))])
                .map_err(err)?;
        }
    }
    // Ground truth: black outlines on top.
    for o in &input.gt {
        let pts = closed(footprint(o.center, o.size, o.yaw));
        let width = if o.background { 1 } else { 2 };
        chart
            .draw_series([PathElement::new(pts, BLACK.stroke_width(width))])
            .map_err(err)?;
    }

    // Trajectory with start (circle) and end (square) markers.
    let traj: Vec<(f64, f64)> = input
        .trajectory
        .iter()
        .map(|p| (f64::from(p[0]), f64::from(p[1])))
        .collect();
    if traj.len() > 1 {
        chart
            .draw_series(LineSeries::new(traj.clone(), PATH_COLOR.stroke_width(2)))
            .map_err(err)?;
    }
    if let (Some(first), Some(last)) = (traj.first(), traj.last()) {
        chart
            .draw_series([Circle::new(*first, 6, PATH_COLOR.filled())])
            .map_err(err)?;
        let s = 0.06;
        chart
            .draw_series([Rectangle::new(
                [(last.0 - s, last.1 - s), (last.0 + s, last.1 + s)],
                PATH_COLOR.filled(),
            )])
            .map_err(err)?;
    }

    // Views: LBVs small blue wedges, GBVs larger red wedges.
    chart
        .draw_series(
            input
                .lbv
                .iter()
                .map(|v| Polygon::new(wedge(v, 0.28), LBV_COLOR.mix(0.22).filled())),
        )
        .map_err(err)?;
    chart
        .draw_series(
            input
                .lbv
                .iter()
                .map(|v| PathElement::new(closed(wedge(v, 0.28)), LBV_COLOR.mix(0.6))),
        )
        .map_err(err)?;
    for v in &input.gbv {
        let pts = wedge(v, 0.5);
        chart
            .draw_series([Polygon::new(pts.clone(), GBV_COLOR.mix(0.45).filled())])
            .map_err(err)?;
        chart
            .draw_series([PathElement::new(closed(pts), GBV_COLOR.stroke_width(2))])
            .map_err(err)?;
    }

    // Labels of estimated foreground objects (class name, offset to reduce clutter).
    let label_style = font(12.0).pos(Pos::new(HPos::Left, VPos::Center));
    for o in input.estimated.iter().filter(|o| !o.background) {
        let (x, y) = (
            f64::from(o.center[0] + o.size[0].max(o.size[1]) * 0.5) + 0.02,
            f64::from(o.center[1]),
        );
        chart
            .draw_series([Text::new(
                o.class.clone(),
                (x, y),
                label_style.color(&darker(colour(&o.class))),
            )])
            .map_err(err)?;
    }
    for o in input.estimated.iter().filter(|o| o.background) {
        let (x, y) = (
            f64::from(o.center[0]),
            f64::from(o.center[1] - o.size[1].max(o.size[0]) * 0.5) - 0.06,
        );
        chart
            .draw_series([Text::new(
                o.class.clone(),
                (x, y),
                font(12.0)
                    .pos(Pos::new(HPos::Center, VPos::Top))
                    .color(&RGBColor(90, 90, 90)),
            )])
            .map_err(err)?;
    }

    draw_legend(&legend_area, &classes, &colour, input)
}

fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    classes: &[&str],
    colour: &dyn Fn(&str) -> RGBColor,
    input: &PlotInput,
) -> Result<(), String> {
    let row = 22i32;
    let mut y = 18i32;
    let text = |s: String, y: i32| Text::new(s, (38, y - 8), font(14.0).color(&BLACK));
    let entries: [(&str, usize); 5] = [
        ("ground truth", 0),
        ("estimate (class colour)", 1),
        ("base trajectory", 2),
        ("GBV", 3),
        ("LBV", 4),
    ];
    for (label, kind) in entries {
        match kind {
            0 => area
                .draw(&Rectangle::new(
                    [(8, y - 7), (30, y + 7)],
                    BLACK.stroke_width(2),
                ))
                .map_err(err)?,
            1 => area
                .draw(&Rectangle::new(
                    [(8, y - 7), (30, y + 7)],
                    PALETTE[0].mix(0.55).filled(),
                ))
                .map_err(err)?,
            2 => area
                .draw(&PathElement::new(
                    vec![(8, y), (30, y)],
                    PATH_COLOR.stroke_width(2),
                ))
                .map_err(err)?,
            3 => area
                .draw(&Polygon::new(
                    vec![(8, y), (30, y - 8), (30, y + 8)],
                    GBV_COLOR.mix(0.6).filled(),
                ))
                .map_err(err)?,
            _ => area
                .draw(&Polygon::new(
                    vec![(14, y), (28, y - 6), (28, y + 6)],
                    LBV_COLOR.mix(0.4).filled(),
                ))
                .map_err(err)?,
        }
        let count = match kind {
            0 => format!(" ({})", input.gt.len()),
            1 => format!(" ({})", input.estimated.len()),
            3 => format!(" ({})", input.gbv.len()),
            4 => format!(" ({} shown)", input.lbv.len()),
            _ => String::new(),
        };
        area.draw(&text(format!("{label}{count}"), y))
            .map_err(err)?;
        y += row;
    }
    y += 8;
    area.draw(&Text::new("classes", (8, y - 8), font(14.0).color(&BLACK)))
        .map_err(err)?;
    y += row;
    let (_, h) = area.dim_in_pixel();
    for class in classes {
        if y > h as i32 - row {
            area.draw(&Text::new("…", (8, y - 8), font(14.0).color(&BLACK)))
                .map_err(err)?;
            break;
        }
        let c = colour(class);
        area.draw(&Rectangle::new(
            [(8, y - 7), (30, y + 7)],
            c.mix(0.7).filled(),
        ))
        .map_err(err)?;
        area.draw(&text((*class).to_string(), y)).map_err(err)?;
        y += row;
    }
    Ok(())
}
