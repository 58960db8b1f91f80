//! Procedural built-in scenes (no asset files), listed by `rtgi list`.
//!
//! Each scene is a function of its validated parameters; generation is deterministic (no RNG: where a
//! scene wants irregularity it hashes integers, see [`shapes::hash`]).

mod atrium;
mod bumpy_glossy;
mod cornell;
mod furnace;
pub mod glints;
mod motion;
mod pillars;
pub mod shapes;
mod spheres_env;
#[cfg(test)]
mod tests;
pub mod translucent;
pub(crate) mod two_rooms;

use crate::error::SceneError;
use crate::params::{ParamSpec, ParamValues};
use crate::scene::Scene;

/// A built-in scene: its name, what it is for, its parameters, and its generator.
pub struct BuiltinScene {
    pub name: &'static str,
    pub description: &'static str,
    pub params: &'static [ParamSpec],
    pub build: fn(&ParamValues) -> Scene,
}

static SCENES: [BuiltinScene; 10] = [
    BuiltinScene {
        name: "cornell",
        description: "the Cornell box from its published measurements, lit by its emissive ceiling quad",
        params: cornell::PARAMS,
        build: cornell::build,
    },
    BuiltinScene {
        name: "cornell-spot",
        description: "the Cornell box lit by one spot light near the ceiling instead of the area light",
        params: cornell::SPOT_PARAMS,
        build: cornell::build_spot,
    },
    BuiltinScene {
        name: "two-rooms",
        description: "a lit and a dark room joined by a doorway in a 5 cm wall: light-leak test",
        params: two_rooms::PARAMS,
        build: two_rooms::build,
    },
    BuiltinScene {
        name: "furnace",
        description: "closed box of emissive grey walls (albedo 0.8, emission 0.2): radiance is exactly 1",
        params: furnace::PARAMS,
        build: furnace::build,
    },
    BuiltinScene {
        name: "bumpy-glossy",
        description: "glossy normal-mapped objects under red, green and blue point lights in a diffuse room",
        params: bumpy_glossy::PARAMS,
        build: bumpy_glossy::build,
    },
    BuiltinScene {
        name: "spheres-env",
        description: "dielectric and metal spheres of increasing roughness under a procedural sky",
        params: spheres_env::PARAMS,
        build: spheres_env::build,
    },
    BuiltinScene {
        name: "pillars",
        description: "a ring of pillars round a trefoil knot on a fine ground, lit by a sky alone: self-shadowing for PRT",
        params: pillars::PARAMS,
        build: pillars::build,
    },
    BuiltinScene {
        name: "atrium",
        description: "Sponza-like courtyard with two storeys of arcades and cloths, sunlit; detail scales to >1 M triangles",
        params: atrium::PARAMS,
        build: atrium::build,
    },
    BuiltinScene {
        name: "translucent",
        description: "a skin sphere and a marble slab (measured media) lit from front and back: subsurface scattering",
        params: translucent::PARAMS,
        build: translucent::build,
    },
    BuiltinScene {
        name: "glints",
        description: "a floor and a sphere of metallic flakes under two small lights: footprint-filtered glints",
        params: glints::PARAMS,
        build: glints::build,
    },
];

/// Every built-in scene, in the order `rtgi list` prints them.
pub fn list() -> &'static [BuiltinScene] {
    &SCENES
}

/// Builds the built-in scene `name` with `settings` (`key=value` pairs) applied over its defaults.
pub fn build(name: &str, settings: &[(String, String)]) -> Result<Scene, SceneError> {
    let entry = list().iter().find(|s| s.name == name).ok_or_else(|| SceneError::UnknownScene {
        name: name.to_string(),
        available: list().iter().map(|s| s.name).collect::<Vec<_>>().join(", "),
    })?;
    let values = ParamValues::from_settings(name, entry.params, settings)
        .map_err(|message| SceneError::InvalidParameter { scene: name.to_string(), message })?;
    let scene = (entry.build)(&values);
    debug_assert!(scene.validate().is_ok(), "{:?}", scene.validate());
    Ok(scene)
}
