//! One module per subcommand.

pub mod dataset;
pub mod eval;
pub mod features;
pub mod simulate;
