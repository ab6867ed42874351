//! Metric-vs-axis line plots (plotters), written as PNG and SVG with an embedded font so no
//! system font libraries are needed.

use std::path::Path;
use std::sync::Once;

use anyhow::Result;
use plotters::coord::Shift;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::prelude::*;

/// One line of a plot.
#[derive(Debug, Clone)]
pub(crate) struct Series {
    /// Legend text.
    pub(crate) name: String,
    /// `(x, y)` points, sorted by x.
    pub(crate) points: Vec<(f64, f64)>,
    /// The plan indices of the cells behind each point (a point may average several).
    pub(crate) cells: Vec<Vec<usize>>,
    /// Draw the points without joining them.
    pub(crate) points_only: bool,
}

/// Where a drawn point landed in the 900×560 image, for making it clickable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Hotspot {
    /// Index into `Plot::series`.
    pub(crate) series: usize,
    /// Index into that series' points.
    pub(crate) point: usize,
    /// Pixel position (x right, y down).
    pub(crate) at: (i32, i32),
}

/// A plot to draw.
#[derive(Debug, Clone)]
pub(crate) struct Plot {
    /// Title.
    pub(crate) title: String,
    /// x-axis description.
    pub(crate) x_label: String,
    /// y-axis description.
    pub(crate) y_label: String,
    /// Lines.
    pub(crate) series: Vec<Series>,
    /// Logarithmic x.
    pub(crate) log_x: bool,
    /// Logarithmic y.
    pub(crate) log_y: bool,
}

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

fn range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let v: Vec<f64> = values
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
fn drawable(plot: &Plot, s: &Series) -> Vec<(usize, (f64, f64))> {
    s.points
        .iter()
        .copied()
        .enumerate()
        .filter(|(_, (x, y))| {
            x.is_finite() && y.is_finite() && (!plot.log_x || *x > 0.0) && (!plot.log_y || *y > 0.0)
        })
        .collect()
}

/// Draws the plot; returns where its points landed.
fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, plot: &Plot) -> Result<Vec<Hotspot>>
where
    DB::ErrorType: 'static,
{
    let err = drawing_error::<DB>(plot);
    // <<Axis ranges and tick positions>>
    root.fill(&WHITE).map_err(&err)?;
    let xs = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0));
    let ys = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1));
    // On a log x axis the automatic ticks are powers of ten, which hides the swept values
    // (nused 25, 50, 150, 300); tick at the distinct x values of the data instead.
    let mut ticks: Vec<f64> = xs.clone().filter(|x| x.is_finite() && *x > 0.0).collect();
    ticks.sort_by(f64::total_cmp);
    ticks.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs());
    let (x0, x1) = range(xs, plot.log_x);
    let (y0, y1) = range(ys, plot.log_y);
    // <<Chart frame>>
    let mut builder = ChartBuilder::on(root);
    builder
        .caption(&plot.title, ("sans-serif", 22))
        .margin(14)
        .x_label_area_size(46)
        .y_label_area_size(70);
    // <<One coordinate system per axis scale>>: each combination of linear and log axes
    // is a different plotters coordinate type.
    let hotspots = match (plot.log_x, plot.log_y) {
        (false, false) => finish(builder.build_cartesian_2d(x0..x1, y0..y1), plot)?,
        (true, false) => finish(
            builder.build_cartesian_2d((x0..x1).log_scale().with_key_points(ticks), y0..y1),
            plot,
        )?,
        (false, true) => finish(
            builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale()),
            plot,
        )?,
        (true, true) => finish(
            builder.build_cartesian_2d(
                (x0..x1).log_scale().with_key_points(ticks),
                (y0..y1).log_scale(),
            ),
            plot,
        )?,
    };
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

/// Draws the mesh, every series and the legend into a built chart; returns where the
/// points landed.
fn finish<'a, DB, X, Y>(chart: BuiltChart<'a, DB, X, Y>, plot: &Plot) -> Result<Vec<Hotspot>>
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
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 16))
        .draw()
        .map_err(&err)?;
    let mut hotspots = Vec::new();
    for (i, s) in plot.series.iter().enumerate() {
        hotspots.extend(draw_series(&mut chart, plot, i, s)?);
    }
    if plot.series.len() > 1 || !plot.series.first().is_some_and(|s| s.name.is_empty()) {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(&err)?;
    }
    Ok(hotspots)
}

/// Draws series `i` (a line unless `points_only`, and its points) with its legend entry;
/// returns where its points landed.
fn draw_series<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    plot: &Plot,
    i: usize,
    s: &Series,
) -> Result<Vec<Hotspot>>
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let err = drawing_error::<DB>(plot);
    let colour = Palette99::pick(i).mix(0.95);
    let drawn = drawable(plot, s);
    let hotspots = drawn
        .iter()
        .map(|(point, p)| Hotspot {
            series: i,
            point: *point,
            at: chart.backend_coord(p),
        })
        .collect();
    let pts: Vec<(f64, f64)> = drawn.into_iter().map(|(_, p)| p).collect();
    if !s.points_only {
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), colour.stroke_width(2)))
            .map_err(&err)?
            .label(s.name.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
    }
    let points = chart
        .draw_series(PointSeries::of_element(
            pts.iter().copied(),
            4,
            colour.filled(),
            &|c, s, st| EmptyElement::at(c) + Circle::new((0, 0), s, st),
        ))
        .map_err(&err)?;
    if s.points_only {
        points
            .label(s.name.clone())
            .legend(move |(x, y)| Circle::new((x + 10, y), 4, colour.filled()));
    }
    Ok(hotspots)
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

/// The size of every plot image.
pub(crate) const PLOT_SIZE: (u32, u32) = (900, 560);

/// Writes `stem.png` and `stem.svg` (900×560); returns where the points are in both.
pub(crate) fn write_plot(stem: &Path, plot: &Plot) -> Result<Vec<Hotspot>> {
    register_font();
    let (w, h) = PLOT_SIZE;
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
    Ok(hotspots)
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

    #[test]
    fn writes_png_and_svg_with_log_axis() {
        let dir = tempfile::tempdir().unwrap();
        let plot = Plot {
            title: "disco vs nused".into(),
            x_label: "nused".into(),
            y_label: "disco_energy".into(),
            series: vec![
                Series {
                    name: "t = 80".into(),
                    points: vec![(25.0, 0.1), (50.0, 0.05), (150.0, 0.01)],
                    cells: vec![vec![0], vec![1], vec![2]],
                    points_only: false,
                },
                Series {
                    name: "t = 6".into(),
                    points: vec![(25.0, 0.02), (50.0, 0.01), (150.0, 0.0)],
                    cells: vec![vec![3], vec![4], vec![5]],
                    points_only: true,
                },
            ],
            log_x: true,
            log_y: false,
        };
        let hotspots = write_plot(&dir.path().join("p"), &plot).unwrap();
        let png = image::open(dir.path().join("p.png")).unwrap().into_rgb8();
        assert_eq!(png.dimensions(), (900, 560));
        assert!(
            png.pixels().any(|p| p.0 != [255, 255, 255]),
            "something was drawn"
        );
        let svg = std::fs::read_to_string(dir.path().join("p.svg")).unwrap();
        assert!(svg.contains("<svg") && svg.contains("t = 80"));
        // Every point has a hotspot inside the image, on the series' colour, left to right
        // along the log axis.
        assert_eq!(hotspots.len(), 6);
        for h in &hotspots {
            let (x, y) = h.at;
            assert!(x > 0 && y > 0 && x < 900 && y < 560, "{h:?}");
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
    }
}
