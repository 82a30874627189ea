//! Signed distance fields (negative inside) and their combinations; the CSG test shapes with
//! sharp features ([`sharp`]) and the measurement of how a mesh keeps them ([`features`]).

mod csg;
pub mod features;
mod shapes;
pub mod sharp;

pub use csg::{Difference, Intersection, Negate, SmoothUnion, Union};
pub use shapes::{Cuboid, Gyroid, Sphere, Torus};
pub use sharp::{BoxMinusSphere, Corner, Cylinder, Fandisk, Features, Frame, Plates, RotatedBox, TwoSpheres};
