//! Metric-vs-axis plots (plotters), written as PNG and SVG with an embedded font so no
//! system font libraries are needed. A plot is one panel or a grid of small multiples that
//! share their axes' ranges; the legend sits in its own column right of the panels, never
//! over data; a point that stands for several cells (seeds) carries its min–max as a bar.

use std::path::Path;
use std::sync::Once;

use anyhow::Result;
use plotters::coord::Shift;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::prelude::*;

/// One plotted value: the mean of its cells' values, with their min and max when it stands
/// for more than one cell.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Point {
    /// Position on the x axis.
    pub(crate) x: f64,
    /// The value (a mean when `cells` has several).
    pub(crate) y: f64,
    /// Smallest and largest value of the cells averaged (none for one cell).
    pub(crate) spread: Option<(f64, f64)>,
    /// Plan indices of the cells behind it.
    pub(crate) cells: Vec<usize>,
}

/// One line of a panel.
#[derive(Debug, Clone)]
pub(crate) struct Series {
    /// Legend text (the same name has the same colour in every panel).
    pub(crate) name: String,
    /// Points, sorted by x.
    pub(crate) points: Vec<Point>,
    /// Draw the points without joining them.
    pub(crate) points_only: bool,
}

/// One of a plot's small multiples.
#[derive(Debug, Clone)]
pub(crate) struct Panel {
    /// What is fixed in it (`multiple = true`); empty for a plot of one panel.
    pub(crate) title: String,
    /// Its lines.
    pub(crate) series: Vec<Series>,
}

/// A plot to draw.
#[derive(Debug, Clone)]
pub(crate) struct Plot {
    /// Title.
    pub(crate) title: String,
    /// x-axis description, with unit.
    pub(crate) x_label: String,
    /// y-axis description, with unit.
    pub(crate) y_label: String,
    /// Panels, drawn left to right, top to bottom.
    pub(crate) panels: Vec<Panel>,
    /// Logarithmic x.
    pub(crate) log_x: bool,
    /// Logarithmic y.
    pub(crate) log_y: bool,
}

/// Where a drawn point landed in the image, for making it clickable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Hotspot {
    /// Index into `Plot::panels`.
    pub(crate) panel: usize,
    /// Index into that panel's series.
    pub(crate) series: usize,
    /// Index into that series' points.
    pub(crate) point: usize,
    /// Pixel position (x right, y down).
    pub(crate) at: (i32, i32),
}

/// What drawing a plot gives back: the image size and where its points landed.
#[derive(Debug, Clone)]
pub(crate) struct Drawn {
    /// Width and height in pixels (the PNG's and the SVG's).
    pub(crate) size: (u32, u32),
    /// Every drawn point.
    pub(crate) hotspots: Vec<Hotspot>,
}

/// The plot area of a plot with one panel, and of each of several.
const ONE_PANEL: (u32, u32) = (680, 516);
const SMALL_PANEL: (u32, u32) = (470, 340);
/// Panels per row.
const COLUMNS: usize = 3;
/// The legend's column and the title's row.
const LEGEND_WIDTH: u32 = 250;
const TITLE_HEIGHT: u32 = 44;

static FONT: Once = Once::new();

fn register_font() {
    FONT.call_once(|| {
        // The font is compiled in; failing to parse it is a build defect, not user input.
        if plotters::style::register_font("sans-serif", FontStyle::Normal, ttf_noto_sans::REGULAR)
            .is_err()
        {
            panic!("embedded Noto Sans font failed to parse");
        }
    });
}

impl Plot {
    /// Names of every series, in order of first appearance: a name's colour.
    fn series_names(&self) -> Vec<&str> {
        let mut names: Vec<&str> = Vec::new();
        for s in self.panels.iter().flat_map(|p| &p.series) {
            if !names.contains(&s.name.as_str()) {
                names.push(&s.name);
            }
        }
        names
    }

    fn has_legend(&self) -> bool {
        self.series_names().iter().any(|n| !n.is_empty())
    }

    /// Rows and columns of panels, and the image size.
    fn layout(&self) -> (usize, usize, (u32, u32)) {
        let n = self.panels.len().max(1);
        let (cols, panel) = if n == 1 {
            (1, ONE_PANEL)
        } else {
            (n.min(COLUMNS), SMALL_PANEL)
        };
        let rows = n.div_ceil(cols);
        let legend = if self.has_legend() { LEGEND_WIDTH } else { 0 };
        let size = (
            panel.0 * cols as u32 + legend,
            panel.1 * rows as u32 + TITLE_HEIGHT,
        );
        (rows, cols, size)
    }

    /// Every value that must be inside the axes: points and their spreads.
    fn extents(&self) -> (Vec<f64>, Vec<f64>) {
        let points = self
            .panels
            .iter()
            .flat_map(|p| &p.series)
            .flat_map(|s| &s.points);
        let xs = points.clone().map(|p| p.x).collect();
        let ys = points
            .flat_map(|p| {
                let (lo, hi) = p.spread.unwrap_or((p.y, p.y));
                [p.y, lo, hi]
            })
            .collect();
        (xs, ys)
    }
}

fn range(values: &[f64], log: bool) -> (f64, f64) {
    let v: Vec<f64> = values
        .iter()
        .copied()
        .filter(|v| v.is_finite() && (!log || *v > 0.0))
        .collect();
    if v.is_empty() {
        return if log { (0.1, 1.0) } else { (0.0, 1.0) };
    }
    let lo = v.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if log {
        let (lo, hi) = if hi / lo < 1.01 {
            (lo / 1.5, hi * 1.5)
        } else {
            (lo, hi)
        };
        (lo / 1.15, hi * 1.15)
    } else {
        let span = if hi - lo < 1e-12 {
            hi.abs().max(1e-3)
        } else {
            hi - lo
        };
        (lo - 0.06 * span, hi + 0.06 * span)
    }
}

/// The points of a series that can be drawn (finite, positive on a log axis), with their
/// indices in the series.
fn drawable<'s>(plot: &Plot, s: &'s Series) -> Vec<(usize, &'s Point)> {
    s.points
        .iter()
        .enumerate()
        .filter(|(_, p)| {
            p.x.is_finite()
                && p.y.is_finite()
                && (!plot.log_x || p.x > 0.0)
                && (!plot.log_y || p.y > 0.0)
        })
        .collect()
}

/// The axes every panel shares.
struct Axes {
    x: (f64, f64),
    y: (f64, f64),
    /// Tick positions on a log x axis: the data's own x values.
    x_ticks: Vec<f64>,
}

/// The title's font size: 21 px, smaller when a long title (every fixed axis named) would
/// run past the image's edges (a character of this font is about 0.55 of its size wide).
fn title_size(title: &str, width: u32) -> u32 {
    let chars = title.chars().count().max(1) as f64;
    let fits = (f64::from(width) - 16.0) / (0.55 * chars);
    (fits.floor() as u32).clamp(11, 21)
}

/// Draws the plot; returns where its points landed.
fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, plot: &Plot) -> Result<Vec<Hotspot>>
where
    DB::ErrorType: 'static,
{
    let err = drawing_error::<DB>(plot);
    root.fill(&WHITE).map_err(&err)?;
    // <<Title row, panel grid and legend column>>
    let (rows, cols, (width, _)) = plot.layout();
    let (title, body) = root.split_vertically(TITLE_HEIGHT);
    title
        .titled(&plot.title, ("sans-serif", title_size(&plot.title, width)))
        .map_err(&err)?;
    let legend_width = if plot.has_legend() { LEGEND_WIDTH } else { 0 };
    let (grid, legend) = body.split_horizontally(width - legend_width);
    // <<Shared axis ranges>>: on a log x axis the automatic ticks are powers of ten, which
    // hides the swept values (nused 25, 50, 150, 300); tick at the data's x values instead.
    let (xs, ys) = plot.extents();
    let mut x_ticks: Vec<f64> = xs
        .iter()
        .copied()
        .filter(|x| x.is_finite() && *x > 0.0)
        .collect();
    x_ticks.sort_by(f64::total_cmp);
    x_ticks.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs());
    let axes = Axes {
        x: range(&xs, plot.log_x),
        y: range(&ys, plot.log_y),
        x_ticks,
    };
    let names = plot.series_names();
    let mut hotspots = Vec::new();
    for (i, area) in grid.split_evenly((rows, cols)).iter().enumerate() {
        if let Some(panel) = plot.panels.get(i) {
            hotspots.extend(
                draw_panel(area, plot, panel, &axes, &names)?
                    .into_iter()
                    .map(|h| Hotspot { panel: i, ..h }),
            );
        }
    }
    if legend_width > 0 {
        draw_legend(&legend, plot, &names)?;
    }
    root.present().map_err(err)?;
    Ok(hotspots)
}

/// A plotters error as one that names the plot.
fn drawing_error<DB: DrawingBackend>(
    plot: &Plot,
) -> impl Fn(DrawingAreaErrorKind<DB::ErrorType>) -> anyhow::Error + '_
where
    DB::ErrorType: 'static,
{
    move |e| anyhow::anyhow!("drawing plot `{}`: {e:?}", plot.title)
}

/// A chart as `ChartBuilder::build_cartesian_2d` returns it.
type BuiltChart<'a, DB, X, Y> = Result<
    ChartContext<'a, DB, Cartesian2d<X, Y>>,
    DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>,
>;

/// Draws one panel with the shared axes; its hotspots have `panel` 0.
fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    plot: &Plot,
    panel: &Panel,
    axes: &Axes,
    names: &[&str],
) -> Result<Vec<Hotspot>>
where
    DB::ErrorType: 'static,
{
    let mut builder = ChartBuilder::on(area);
    if !panel.title.is_empty() {
        builder.caption(&panel.title, ("sans-serif", 17));
    }
    builder
        .margin(12)
        .x_label_area_size(46)
        .y_label_area_size(76);
    let ((x0, x1), (y0, y1)) = (axes.x, axes.y);
    let ticks = axes.x_ticks.clone();
    // <<One coordinate system per axis scale>>: each combination of linear and log axes
    // is a different plotters coordinate type.
    match (plot.log_x, plot.log_y) {
        (false, false) => finish(
            builder.build_cartesian_2d(x0..x1, y0..y1),
            plot,
            panel,
            names,
        ),
        (true, false) => finish(
            builder.build_cartesian_2d((x0..x1).log_scale().with_key_points(ticks), y0..y1),
            plot,
            panel,
            names,
        ),
        (false, true) => finish(
            builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale()),
            plot,
            panel,
            names,
        ),
        (true, true) => finish(
            builder.build_cartesian_2d(
                (x0..x1).log_scale().with_key_points(ticks),
                (y0..y1).log_scale(),
            ),
            plot,
            panel,
            names,
        ),
    }
}

/// Draws the mesh and every series of a panel into a built chart; returns where the points
/// landed.
fn finish<'a, DB, X, Y>(
    chart: BuiltChart<'a, DB, X, Y>,
    plot: &Plot,
    panel: &Panel,
    names: &[&str],
) -> Result<Vec<Hotspot>>
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let err = drawing_error::<DB>(plot);
    let mut chart = chart.map_err(&err)?;
    chart
        .configure_mesh()
        .x_desc(plot.x_label.as_str())
        .x_label_formatter(&|v| tick_label(*v))
        .y_desc(plot.y_label.as_str())
        .y_label_formatter(&|v| tick_label(*v))
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .draw()
        .map_err(&err)?;
    let mut hotspots = Vec::new();
    for (i, s) in panel.series.iter().enumerate() {
        let colour = names.iter().position(|n| *n == s.name).unwrap_or(i);
        hotspots.extend(draw_series(&mut chart, plot, i, colour, s)?);
    }
    Ok(hotspots)
}

/// The colour of the `index`-th series name.
fn colour(index: usize) -> RGBAColor {
    Palette99::pick(index).mix(0.95)
}

/// Draws series `i` (a line unless `points_only`, its points and their spread bars);
/// returns where its points landed.
fn draw_series<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    plot: &Plot,
    i: usize,
    colour_index: usize,
    s: &Series,
) -> Result<Vec<Hotspot>>
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let err = drawing_error::<DB>(plot);
    let colour = colour(colour_index);
    let drawn = drawable(plot, s);
    let hotspots = drawn
        .iter()
        .map(|(point, p)| Hotspot {
            panel: 0,
            series: i,
            point: *point,
            at: chart.backend_coord(&(p.x, p.y)),
        })
        .collect();
    let pts: Vec<(f64, f64)> = drawn.iter().map(|(_, p)| (p.x, p.y)).collect();
    if !s.points_only {
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), colour.stroke_width(2)))
            .map_err(&err)?;
    }
    let bars = drawn.iter().filter_map(|(_, p)| {
        let (lo, hi) = p.spread?;
        let positive = !plot.log_y || lo > 0.0;
        (positive && lo.is_finite() && hi.is_finite())
            .then(|| ErrorBar::new_vertical(p.x, lo, p.y, hi, colour.stroke_width(2), 10))
    });
    chart.draw_series(bars).map_err(&err)?;
    chart
        .draw_series(PointSeries::of_element(
            pts.iter().copied(),
            4,
            colour.filled(),
            &|c, s, st| EmptyElement::at(c) + Circle::new((0, 0), s, st),
        ))
        .map_err(&err)?;
    Ok(hotspots)
}

/// The legend, in its own column: one entry per series name, and what a bar means when
/// any point has one.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    plot: &Plot,
    names: &[&str],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let err = drawing_error::<DB>(plot);
    let style = ("sans-serif", 14).into_font().color(&BLACK);
    let lined = |name: &str| {
        plot.panels
            .iter()
            .flat_map(|p| &p.series)
            .any(|s| s.name == name && !s.points_only)
    };
    let mut y = 28;
    for (i, name) in names.iter().enumerate() {
        let c = colour(i);
        if lined(name) {
            area.draw(&PathElement::new(vec![(8, y), (34, y)], c.stroke_width(2)))
                .map_err(&err)?;
        }
        area.draw(&Circle::new((21, y), 4, c.filled()))
            .map_err(&err)?;
        let text: String = if name.chars().count() > 30 {
            name.chars().take(29).chain(['…']).collect()
        } else {
            name.to_string()
        };
        area.draw(&Text::new(text, (42, y - 9), style.clone()))
            .map_err(&err)?;
        y += 24;
    }
    let spread = plot
        .panels
        .iter()
        .flat_map(|p| &p.series)
        .flat_map(|s| &s.points)
        .any(|p| p.spread.is_some());
    if spread {
        area.draw(&Text::new(
            "bars: min–max over seeds",
            (8, y),
            ("sans-serif", 13).into_font().color(&BLACK.mix(0.7)),
        ))
        .map_err(&err)?;
    }
    Ok(())
}

/// A tick label: three significant digits without trailing zeros (`25`, `0.2`, `0.000125`).
fn tick_label(v: f64) -> String {
    let s = super::figures::sig3(v as f32);
    if s.contains('.') && !s.contains('e') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Writes `stem.png` and `stem.svg`; returns their size and where the points are in both.
pub(crate) fn write_plot(stem: &Path, plot: &Plot) -> Result<Drawn> {
    register_font();
    let (_, _, (w, h)) = plot.layout();
    let mut buffer = vec![0u8; (w * h * 3) as usize];
    let hotspots = {
        let root = BitMapBackend::with_buffer(&mut buffer, (w, h)).into_drawing_area();
        draw(&root, plot)?
    };
    volphot::write_png_rgb8(&stem.with_extension("png"), w as usize, h as usize, &buffer)?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        draw(&root, plot)?;
    }
    volphot::write_atomic(&stem.with_extension("svg"), svg.as_bytes())?;
    Ok(Drawn {
        size: (w, h),
        hotspots,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick_label(25.0), "25");
        assert_eq!(tick_label(150.0), "150");
        assert_eq!(tick_label(0.2), "0.2");
        assert_eq!(tick_label(0.0005), "0.0005");
        assert_eq!(tick_label(40000.0), "40000");
        assert_eq!(tick_label(0.000125), "0.000125");
        assert_eq!(tick_label(1.0e-6), "1.00e-6");
    }

    fn points(values: &[(f64, f64)], first_cell: usize) -> Vec<Point> {
        values
            .iter()
            .enumerate()
            .map(|(i, &(x, y))| Point {
                x,
                y,
                spread: None,
                cells: vec![first_cell + i],
            })
            .collect()
    }

    fn plot(panels: Vec<Panel>) -> Plot {
        Plot {
            title: "disco vs nused".into(),
            x_label: "nused".into(),
            y_label: "disco_energy [1]".into(),
            panels,
            log_x: true,
            log_y: false,
        }
    }

    #[test]
    fn writes_png_and_svg_with_log_axis() {
        let dir = tempfile::tempdir().unwrap();
        let plot = plot(vec![Panel {
            title: String::new(),
            series: vec![
                Series {
                    name: "t = 80".into(),
                    points: points(&[(25.0, 0.1), (50.0, 0.05), (150.0, 0.01)], 0),
                    points_only: false,
                },
                Series {
                    name: "t = 6".into(),
                    points: points(&[(25.0, 0.02), (50.0, 0.01), (150.0, 0.0)], 3),
                    points_only: true,
                },
            ],
        }]);
        let drawn = write_plot(&dir.path().join("p"), &plot).unwrap();
        let png = image::open(dir.path().join("p.png")).unwrap().into_rgb8();
        assert_eq!(png.dimensions(), drawn.size);
        assert_eq!(
            drawn.size,
            (ONE_PANEL.0 + LEGEND_WIDTH, ONE_PANEL.1 + TITLE_HEIGHT)
        );
        let svg = std::fs::read_to_string(dir.path().join("p.svg")).unwrap();
        assert!(svg.contains("<svg") && svg.contains("t = 80"));
        // Every point has a hotspot inside the panel (left of the legend column), on the
        // series' colour, left to right along the log axis.
        let hotspots = &drawn.hotspots;
        assert_eq!(hotspots.len(), 6);
        for h in hotspots {
            let (x, y) = h.at;
            assert!(
                x > 0 && y > 0 && (x as u32) < ONE_PANEL.0 && (y as u32) < drawn.size.1,
                "{h:?}"
            );
            let pixel = png.get_pixel(x as u32, y as u32).0;
            assert_ne!(pixel, [255, 255, 255], "{h:?} is on a drawn point");
        }
        let first: Vec<i32> = hotspots
            .iter()
            .filter(|h| h.series == 0)
            .map(|h| h.at.0)
            .collect();
        assert!(first.windows(2).all(|w| w[0] < w[1]), "{first:?}");
        assert!(
            hotspots[0].at.1 < hotspots[2].at.1,
            "higher values are higher up"
        );
        // The legend column holds ink; nothing of the legend is inside the panel's corner
        // where the old in-chart legend sat over the data.
        let legend_ink = (ONE_PANEL.0..drawn.size.0)
            .flat_map(|x| (TITLE_HEIGHT..drawn.size.1).map(move |y| (x, y)))
            .filter(|&(x, y)| png.get_pixel(x, y).0 != [255, 255, 255])
            .count();
        assert!(legend_ink > 100, "the legend is drawn in its column");
    }

    #[test]
    fn small_multiples_share_axes_and_colours() {
        let dir = tempfile::tempdir().unwrap();
        let series = |name: &str, y: f64, cell: usize| Series {
            name: name.into(),
            points: vec![Point {
                x: 10.0,
                y,
                spread: Some((y * 0.9, y * 1.1)),
                cells: vec![cell, cell + 1],
            }],
            points_only: false,
        };
        let plot = plot(vec![
            Panel {
                title: "multiple = false".into(),
                series: vec![series("a", 1.0, 0)],
            },
            Panel {
                title: "multiple = true".into(),
                series: vec![series("b", 2.0, 2), series("a", 1.0, 4)],
            },
        ]);
        let drawn = write_plot(&dir.path().join("p"), &plot).unwrap();
        assert_eq!(
            drawn.size,
            (
                2 * SMALL_PANEL.0 + LEGEND_WIDTH,
                SMALL_PANEL.1 + TITLE_HEIGHT
            )
        );
        let png = image::open(dir.path().join("p.png")).unwrap().into_rgb8();
        let at = |panel: usize, series: usize| {
            let h = drawn
                .hotspots
                .iter()
                .find(|h| h.panel == panel && h.series == series)
                .unwrap();
            (h.at, png.get_pixel(h.at.0 as u32, h.at.1 as u32).0)
        };
        // Series "a" has one colour and one height in both panels (shared y range).
        let ((_, y0), c0) = at(0, 0);
        let ((x1, y1), c1) = at(1, 1);
        assert_eq!(c0, c1);
        assert_eq!(y0, y1);
        assert!(
            x1 as u32 > SMALL_PANEL.0,
            "the second panel is right of the first"
        );
    }

    #[test]
    fn a_long_title_is_set_smaller_to_fit_the_image() {
        assert_eq!(title_size("rmse vs σt(d_min)", 930), 21);
        let long = "disco_excess vs σt(d_min) — scene = foot, nused = 50, α = 0.5, photons = 40000, iterations = 16, eye_rays = replayed, radius = auto, maxdist = 0.1";
        let size = title_size(long, 930);
        assert!(
            size < 21 && f64::from(size) * 0.55 * long.chars().count() as f64 <= 930.0,
            "{size}"
        );
    }
}
