//! The terminal user interface (ratatui): app state, a pure update function and one view per pane.
