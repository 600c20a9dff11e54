pub mod coverage;
pub mod finite;
pub mod planted;
