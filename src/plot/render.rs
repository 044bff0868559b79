//! Drawing a figure into its SVG and PNG files, each through a temporary file.

use super::*;

/// A validated chart that can draw itself on any `plotters` backend.
pub(super) trait Figure {
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>;
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

/// Draws `figure` into `<base>.svg` and `<base>.png`, each through a temporary file.
pub(super) fn write_figure<F: Figure>(figure: &F, base: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let font = font()?;
    if let Some(parent) = base.parent().filter(|p| !p.as_os_str().is_empty()) {
        fs::create_dir_all(parent).map_err(io_error(parent))?;
    }
    let svg = with_suffix(base, ".svg");
    let png = with_suffix(base, ".png");
    write_svg(figure, font, &svg, &with_suffix(base, ".tmp.svg"))?;
    write_png(figure, font, &png, &with_suffix(base, ".tmp.png"))?;
    Ok(vec![svg, png])
}

pub(super) fn write_svg<F: Figure>(
    figure: &F,
    font: &'static FontRef<'static>,
    target: &Path,
    tmp: &Path,
) -> Result<(), PlotError> {
    let mut text = String::new();
    {
        let root = Typeset {
            inner: SVGBackend::with_string(&mut text, (WIDTH, HEIGHT)),
            font,
            raster: false,
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
    let written = File::create(tmp)
        .and_then(|mut file| {
            file.write_all(text.as_bytes())?;
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

pub(super) fn write_png<F: Figure>(
    figure: &F,
    font: &'static FontRef<'static>,
    target: &Path,
    tmp: &Path,
) -> Result<(), PlotError> {
    let drawn = {
        let root = Typeset {
            inner: BitMapBackend::new(tmp, (WIDTH, HEIGHT)),
            font,
            raster: true,
        }
        .into_drawing_area();
        figure
            .draw(&root)
            .and_then(|()| root.present())
            .map_err(|e| e.to_string())
        // NOTE: on error the backend still saves what it has when dropped here; the partial
        // temporary file is removed below and never renamed.
    };
    if let Err(message) = drawn {
        let _ = fs::remove_file(tmp);
        return Err(PlotError::Draw {
            path: target.to_path_buf(),
            message,
        });
    }
    let written = File::open(tmp)
        .and_then(|file| file.sync_all())
        .and_then(|()| fs::rename(tmp, target));
    written.map_err(|source| {
        let _ = fs::remove_file(tmp);
        PlotError::Io {
            path: target.to_path_buf(),
            source,
        }
    })
}
