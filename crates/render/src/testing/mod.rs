//! Statistical test harnesses shared by the unit tests.

pub mod chi2;
