//! Helpers shared by the data crate's tests.

// Each test file uses a part of these helpers.
#![allow(dead_code)]

pub mod xlsx;
