//! Drawing a figure into its SVG and PNG files, each through a temporary file.

use std::sync::Arc;

use resvg::{tiny_skia, usvg};

use super::*;

/// A validated chart that can draw itself on any `plotters` backend.
pub(super) trait Figure {
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>;

    /// Width and height in pixels (the PNG size; the SVG uses the same user units).
    fn size(&self) -> (u32, u32) {
        (WIDTH, HEIGHT)
    }
}

/// The embedded font, parsed once per process. It is also registered with `plotters` under
/// `sans-serif`, so any text that bypasses `Typeset` still renders.
pub(super) fn font() -> Result<&'static FontRef<'static>, PlotError> {
    static FONT_REF: OnceLock<Result<FontRef<'static>, String>> = OnceLock::new();
    FONT_REF
        .get_or_init(|| {
            let invalid = |_| "the embedded file is not a valid TrueType font".to_string();
            register_font(FONT, FontStyle::Normal, FONT_BYTES).map_err(invalid)?;
            FontRef::try_from_slice(FONT_BYTES).map_err(|e| e.to_string())
        })
        .as_ref()
        .map_err(|message| PlotError::Font(message.clone()))
}

/// `base` with `suffix` appended (not `with_extension`, which would eat a `.5` in `kappa_0.5`).
pub(super) fn with_suffix(base: &Path, suffix: &str) -> PathBuf {
    let mut name = base.as_os_str().to_owned();
    name.push(suffix);
    PathBuf::from(name)
}

pub(super) fn io_error(path: &Path) -> impl FnOnce(io::Error) -> PlotError + '_ {
    move |source| PlotError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Draws `figure` into `<base>.svg` and renders that SVG into `<base>.png`, each file written
/// through a temporary file.
pub(super) fn write_figure<F: Figure>(figure: &F, base: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let font = font()?;
    if let Some(parent) = base.parent().filter(|p| !p.as_os_str().is_empty()) {
        fs::create_dir_all(parent).map_err(io_error(parent))?;
    }
    let svg_path = with_suffix(base, ".svg");
    let png_path = with_suffix(base, ".png");
    let svg = draw_svg(figure, font, &svg_path)?;
    let png = rasterise(&svg, figure.size(), &png_path)?;
    write_atomically(&svg_path, &with_suffix(base, ".tmp.svg"), svg.as_bytes())?;
    write_atomically(&png_path, &with_suffix(base, ".tmp.png"), &png)?;
    Ok(vec![svg_path, png_path])
}

/// The figure as SVG text.
pub(super) fn draw_svg<F: Figure>(
    figure: &F,
    font: &'static FontRef<'static>,
    target: &Path,
) -> Result<String, PlotError> {
    let mut text = String::new();
    {
        let root = Typeset {
            inner: SVGBackend::with_string(&mut text, figure.size()),
            font,
        }
        .into_drawing_area();
        figure
            .draw(&root)
            .and_then(|()| root.present())
            .map_err(|e| PlotError::Draw {
                path: target.to_path_buf(),
                message: e.to_string(),
            })?;
    }
    Ok(text)
}

/// The SVG rendered by resvg into PNG bytes, its `sans-serif` text set in the embedded DejaVu
/// Sans (the only font it knows, so the PNG does not depend on the machine's fonts).
fn rasterise(svg: &str, (width, height): (u32, u32), target: &Path) -> Result<Vec<u8>, PlotError> {
    static FONTS: OnceLock<Arc<usvg::fontdb::Database>> = OnceLock::new();
    let fonts = FONTS.get_or_init(|| {
        let mut fonts = usvg::fontdb::Database::new();
        fonts.load_font_data(FONT_BYTES.to_vec());
        fonts.set_sans_serif_family(FONT_FAMILY);
        Arc::new(fonts)
    });
    let failed = |message: String| PlotError::Draw {
        path: target.to_path_buf(),
        message,
    };
    let options = usvg::Options {
        font_family: FONT_FAMILY.to_owned(),
        fontdb: Arc::clone(fonts),
        ..usvg::Options::default()
    };
    let tree = usvg::Tree::from_str(svg, &options).map_err(|e| failed(e.to_string()))?;
    let mut pixmap = tiny_skia::Pixmap::new(width, height).expect("a figure size above zero");
    resvg::render(
        &tree,
        tiny_skia::Transform::identity(),
        &mut pixmap.as_mut(),
    );
    pixmap.encode_png().map_err(|e| failed(e.to_string()))
}

/// Writes `bytes` to `tmp`, flushes it to disk and renames it to `target`, so a killed process
/// never leaves a truncated figure.
fn write_atomically(target: &Path, tmp: &Path, bytes: &[u8]) -> Result<(), PlotError> {
    let written = File::create(tmp)
        .and_then(|mut file| {
            file.write_all(bytes)?;
            file.sync_all()
        })
        .and_then(|()| fs::rename(tmp, target));
    written.map_err(|source| {
        // Best effort: the error that matters is the one reported.
        let _ = fs::remove_file(tmp);
        PlotError::Io {
            path: target.to_path_buf(),
            source,
        }
    })
}
