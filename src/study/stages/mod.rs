//! The stages of every method, one file each, named as `repose stages`
//! prints the stage (with the method's variant where two methods differ):
//! a method is its stage list ([`super::plan::StudySpec`]), and a stage
//! reaches what earlier stages wrote through the study's layout
//! ([`super::dir::StudyDir`]).
//!
//! | stage | file | methods |
//! | --- | --- | --- |
//! | noise | [`noise`] | he2019 noise-aware |
//! | screen | [`screen`] | response surface |
//! | design | [`design`] (he2019's LHS); the design studies' designs are built in [`rsm`] and [`sensitivity`] | all |
//! | simulate | [`simulate`] | he2019 |
//! | fit | [`fit_network`] (GA-BP), [`fit_gp`] (GP of he2019), [`rsm`] (quadratic, or a GP of a design study: `rsm::gp_surface`) | all |
//! | fine | [`fine`] | he2019 two-level |
//! | adaptive | [`adaptive`] | he2019 noise-aware |
//! | search | [`search_tolerance`], [`search_probability`], desirability in [`rsm`] | all |
//! | sensitivity | [`sensitivity`] | yan2015 |
//! | verify | [`verify_candidates`] (he2019's candidates), [`verify_optimum`] (a design study's optimum) | all |
//! | transfer | [`transfer`] | he2019 |

pub mod adaptive;
pub mod design;
pub mod fine;
pub mod fit_gp;
pub mod fit_network;
pub mod noise;
pub mod rsm;
pub mod screen;
pub mod search_probability;
pub mod search_tolerance;
pub mod sensitivity;
pub mod simulate;
pub mod transfer;
pub mod verify_candidates;
pub mod verify_optimum;
