//! Crossing gaps with formed assemblies (THESIS 3.5.2, 5.2.4): the assembly a 2-D formation
//! left ([`formed`]), driven across in the 3-D world under the stability gate ([`drive3d`]),
//! and the crossing that ends `puzzlebot demo` ([`demo`]).

pub mod demo;
pub mod drive3d;
pub mod formed;
