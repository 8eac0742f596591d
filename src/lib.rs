//! # grainstat
//!
//! Exact quasi-static discrete element analysis of granular materials in 2D: circular
//! grains with Hertz-Mindlin (sand) or linear cemented (sandstone) contacts and Coulomb
//! slip, after S. van Baars, *Discrete Element Analysis of Granular Materials* (TU Delft,
//! 1996). Where the thesis relaxed grain by grain, grainstat solves each load increment for
//! the equilibrium of all grains at once.
//!
//! ## One load increment
//! [`Simulation::run_increment`](simulation::Simulation::run_increment) reads like the
//! pipeline:
//!
//! 1. apply the increment: prescribed walls move, wall stresses change ([`scene`]);
//! 2. every pair of the friends lists a contact of the increment ([`geometry`]);
//! 3. contact laws, friction as a potential with its normal force lagged ([`contact`]);
//! 4. assembly of the residual and the projected Hessian into a fixed pattern
//!    ([`assembly`]);
//! 5. the minimisation of the increment's potential: projected Newton with a line search on
//!    the potential and a Cholesky with a cached symbolic factorisation ([`solver`]),
//!    contacts made and lost wherever the iterate puts them, bonds broken one at a time,
//!    the load path followed in halves where it does not converge;
//! 6. measurements ([`measure`]: wall stresses, eq. A.41 and its regional form A.40,
//!    contact counts, grain rotations) and output ([`output`]).
//!
//! Sign conventions: compression is positive (forces and stresses), rotations are
//! anticlockwise, `n` points from side `a` to grain `b` of a contact and `t` is `n` turned
//! 90 degrees anticlockwise. Symbols: `u` is the displacement of the unknowns over the
//! current load increment, `du` one Newton step of it.

#![warn(missing_docs)]

pub mod assembly;
pub mod contact;
pub mod error;
pub mod estimate;
pub mod geometry;
pub mod measure;
mod memory;
pub mod output;
pub mod parallel;
pub mod run;
pub mod sample;
pub mod samples;
pub mod scene;
pub mod simulation;
pub mod solver;
pub mod spread;
pub mod state;
pub mod study;
pub mod sweep;

pub use error::{Error, InputError, NumericError, Result};
pub use memory::give_back_large_blocks;

/// The README's Rust example, compiled and run as a doctest.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
