//! One module per subcommand.

pub mod dataset;
pub mod features;
pub mod simulate;
