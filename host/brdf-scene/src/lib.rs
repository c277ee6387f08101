//! Targets and sensors: the laser radar cross-section (LRCS) of a meshed target from its
//! materials' BRDFs, the BRDF queries a scene makes, and the cheapest device representation
//! of each material that keeps the scene's σ within a budget.
//!
//! ```
//! use brdf_core::{AnyModel, ModelKind};
//! use brdf_scene::scene::{Mode, Scene, SceneMaterial, Sensor};
//! use brdf_scene::shapes::MeshBuilder;
//!
//! // A Lambertian sphere of radius 1 m, albedo 0.5, seen from one direction.
//! let mut b = MeshBuilder::new();
//! b.icosphere(1.0, 4, "ball");
//! let lambert = AnyModel::new(ModelKind::Lambert, &[0.5]).unwrap();
//! let sensor = Sensor { mode: Mode::Monostatic, azimuth_deg: vec![0.0], elevation_deg: vec![0.0] };
//! let scene = Scene::new("ball".into(), b.build("ball").unwrap(), vec![SceneMaterial::new("*", lambert)], sensor).unwrap();
//! let sigma = brdf_scene::lrcs::lrcs(&scene, &|| {}).aspects[0].lrcs;
//! let exact = 8.0 / 3.0 * std::f64::consts::PI * 0.5; // (8/3) pi rho r^2
//! assert!((sigma - exact).abs() < 0.01 * exact);
//! ```

pub mod eval;
pub mod image;
pub mod ladder;
pub mod lrcs;
pub mod mesh;
pub mod occlusion;
pub mod profile;
pub mod queries;
pub mod represent;
pub mod scene;
pub mod select;
pub mod shapes;
