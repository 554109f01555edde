//! The figures' error: a figure that could not be drawn (the message says why). Callers turn it into a
//! warning: a figure is a convenience, never a reason for a run to fail.

use plotters::drawing::DrawingAreaErrorKind;

/// A figure that could not be drawn.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct FigureError(pub String);

/// Results of drawing.
pub type Result<T> = std::result::Result<T, FigureError>;

impl<E: std::error::Error + Send + Sync> From<DrawingAreaErrorKind<E>> for FigureError {
    fn from(e: DrawingAreaErrorKind<E>) -> Self {
        FigureError(e.to_string())
    }
}

impl From<std::io::Error> for FigureError {
    fn from(e: std::io::Error) -> Self {
        FigureError(e.to_string())
    }
}

/// A [`FigureError`] from a format string.
#[macro_export]
macro_rules! fig_err {
    ($($t:tt)*) => {
        $crate::error::FigureError(format!($($t)*))
    };
}
