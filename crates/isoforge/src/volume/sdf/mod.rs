//! Signed distance fields (negative inside) and their combinations.

mod csg;
mod shapes;

pub use csg::{Difference, Intersection, Negate, SmoothUnion, Union};
pub use shapes::{Cuboid, Gyroid, Sphere, Torus};
