//! The virtual arm's mechanics: [`kinematics`] (the models' forward and inverse
//! kinematics, and their dynamics), [`trajectory`] (speed profiles, paths and blends),
//! [`force`] (force mode and contact), [`pose`] (pose arithmetic), [`vec3`] (three-vectors)
//! and [`world_model`] (named frames). Nothing here knows the built-ins, the controller or
//! the scheduler.

pub(crate) mod force;
pub mod kinematics;
pub(crate) mod pose;
pub(crate) mod trajectory;
pub(crate) mod vec3;
pub mod world_model;
