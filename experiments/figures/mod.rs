//! Figures and tables, the bottom room of the application: it uses the
//! library and no other room, so every room may draw with it.

pub mod panels;
pub mod plot;
pub mod render_difference;
pub mod table;
