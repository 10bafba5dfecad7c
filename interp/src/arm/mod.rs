//! The virtual arm's mechanics: [`kinematics`] (the models' forward and inverse
//! kinematics, and their dynamics), [`trajectory`] (speed profiles, paths and blends),
//! [`force`] (force mode and contact), [`pose`] (pose arithmetic), [`world_model`]
//! (named frames) and [`world_set`] (the settings a test sets on the arm and the world).
//! Nothing here knows the built-ins or the scheduler.

pub(crate) mod force;
pub mod kinematics;
pub(crate) mod pose;
pub(crate) mod trajectory;
pub mod world_model;
pub(crate) mod world_set;
