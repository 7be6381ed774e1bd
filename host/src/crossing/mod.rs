//! Crossing gaps with formed assemblies (THESIS 3.5.2, 5.2.4): the assembly a 2-D formation
//! left ([`formed`]), driven across under the stability gate by the host's crossing
//! behaviour ([`controller`]) in the 3-D world ([`drive3d`]) or on a fleet, and the crossing
//! that ends `puzzlebot demo` ([`demo`]).

pub mod controller;
pub mod demo;
pub mod drive3d;
pub mod formed;
pub mod world_run;
