//! The one font every PNG plot of fleetmap draws its text with (bandit progress, the DFS,
//! bandit and runway studies): DejaVu Sans, shipped in `assets/fonts` and embedded once, so
//! that plots look the same on a machine with no system fonts.

use plotters::style::FontStyle;
use std::sync::Once;

static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

/// Make "sans-serif" resolve to the embedded DejaVu Sans (once per process; call before
/// drawing).
pub(crate) fn register_font() {
    REGISTER.call_once(|| {
        // The shipped font is a valid TrueType file; if it were not, the plots would lack
        // their text only, which plotters then reports as a drawing error.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}
