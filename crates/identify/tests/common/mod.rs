pub mod coverage;
pub mod finite;
pub mod honesty;
pub mod planted;
