//! One module per subcommand.

pub mod bench;
pub mod classify;
pub mod dataset;
pub mod demo;
pub mod eval;
pub mod experiment;
pub mod features;
pub mod import;
pub mod localize;
pub mod pretrain;
pub mod run;
pub mod simulate;
pub mod train;
pub mod view;
