pub mod finite;
pub mod plans;
pub mod planted;
