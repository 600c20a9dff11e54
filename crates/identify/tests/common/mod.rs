pub mod plans;
pub mod planted;
