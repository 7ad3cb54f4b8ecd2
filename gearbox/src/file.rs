//! The gearbox file as serde reads it (gearbox-file.md §1). Every table refuses keys it does
//! not know. Key groups (a gear's data, a body's, a mesh's) are written once and put together
//! by `keys!`, since serde's `flatten` cannot refuse unknown keys.

use serde::Deserialize;
use toml::Spanned;

/// A struct of `Option` keys from the named groups plus its own keys.
macro_rules! keys {
    ($(#[$meta:meta])* $name:ident [$($group:ident),*] { $($own:tt)* }) => {
        keys!(@acc [$(#[$meta])*] $name [$($group),*] { $($own)* });
    };
    (@acc $meta:tt $name:ident [gear $(, $rest:ident)*] { $($acc:tt)* }) => {
        keys!(@acc $meta $name [$($rest),*] { $($acc)*
            pub z: Option<i64>,
            pub x: Option<f64>,
            pub internal: Option<bool>,
            pub mount: Option<f64>,
            pub mount_deg: Option<f64>,
            pub tip_diameter: Option<f64>,
            pub bore_radius: Option<f64>,
            pub tip_relief: Option<f64>,
            pub tip_relief_length: Option<f64>,
            pub ecc: Option<f64>,
            pub ecc_phase: Option<f64>,
            pub ecc_phase_deg: Option<f64>,
            pub pitch_errors: Option<Vec<f64>>,
        });
    };
    // What a gear shares with [defaults].
    (@acc $meta:tt $name:ident [material $(, $rest:ident)*] { $($acc:tt)* }) => {
        keys!(@acc $meta $name [$($rest),*] { $($acc)*
            pub module: Option<f64>,
            pub pressure_angle: Option<f64>,
            pub pressure_angle_deg: Option<f64>,
            pub width: Option<f64>,
            pub addendum: Option<f64>,
            pub dedendum: Option<f64>,
            pub rack_tip_radius: Option<f64>,
            #[serde(rename = "E")]
            pub e: Option<f64>,
            pub nu: Option<f64>,
        });
    };
    (@acc $meta:tt $name:ident [body $(, $rest:ident)*] { $($acc:tt)* }) => {
        keys!(@acc $meta $name [$($rest),*] { $($acc)*
            #[serde(rename = "J")]
            pub j: Option<f64>,
            pub m: Option<f64>,
            pub c: Option<f64>,
            pub tau: Option<f64>,
            pub w_start: Option<f64>,
            pub angle_start: Option<f64>,
            pub drive: Option<String>,
            pub tau_ripple: Option<f64>,
            pub ripple_order: Option<f64>,
            pub ripple_phase: Option<f64>,
            pub lateral: Option<bool>,
            pub k_x: Option<f64>,
            pub k_y: Option<f64>,
            pub c_x: Option<f64>,
            pub c_y: Option<f64>,
            pub x_start: Option<f64>,
            pub y_start: Option<f64>,
            pub vx_start: Option<f64>,
            pub vy_start: Option<f64>,
        });
    };
    (@acc $meta:tt $name:ident [orbit $(, $rest:ident)*] { $($acc:tt)* }) => {
        keys!(@acc $meta $name [$($rest),*] { $($acc)*
            pub carrier: Option<String>,
            pub orbit_angle: Option<f64>,
            pub orbit_angle_deg: Option<f64>,
            pub pin_error_r: Option<f64>,
            pub pin_error_t: Option<f64>,
        });
    };
    // What a mesh shares with [defaults].
    (@acc $meta:tt $name:ident [pair $(, $rest:ident)*] { $($acc:tt)* }) => {
        keys!(@acc $meta $name [$($rest),*] { $($acc)*
            pub backlash: Option<f64>,
            pub chi: Option<f64>,
            pub damping_ratio: Option<f64>,
            pub mu: Option<f64>,
            pub v_reg: Option<f64>,
            pub contact_model: Option<i64>,
            pub contacts_per_flank: Option<i64>,
            pub backward_contacts: Option<bool>,
            pub tip_relief_shape: Option<i64>,
            pub k_lumped: Option<f64>,
            pub c_lumped: Option<f64>,
            pub k_lumped_varies: Option<bool>,
        });
    };
    (@acc $meta:tt $name:ident [placed $(, $rest:ident)*] { $($acc:tt)* }) => {
        keys!(@acc $meta $name [$($rest),*] { $($acc)*
            pub center_angle: Option<f64>,
            pub center_angle_deg: Option<f64>,
            pub center_distance_error: Option<f64>,
            pub dte_start: Option<f64>,
            pub paper: Option<Paper>,
        });
    };
    (@acc [$(#[$meta:meta])*] $name:ident [] { $($acc:tt)* }) => {
        $(#[$meta])*
        #[derive(Deserialize, Debug, Default, Clone)]
        #[serde(deny_unknown_fields)]
        pub struct $name { $($acc)* }
    };
}

keys! {
    /// The whole file.
    File [] {
        pub name: String,
        pub description: Option<String>,
        pub static_start: Option<bool>,
        #[serde(default)]
        pub defaults: Defaults,
        #[serde(default)]
        pub planetary: Vec<Spanned<Planetary>>,
        #[serde(default)]
        pub gear: Vec<Spanned<GearEntry>>,
        #[serde(default)]
        pub body: Vec<Spanned<BodyEntry>>,
        #[serde(default)]
        pub mesh: Vec<Spanned<MeshEntry>>,
        #[serde(default)]
        pub shaft: Vec<Spanned<ShaftEntry>>,
        #[serde(default)]
        pub solver: SolverEntry,
    }
}

keys! {
    /// `[defaults]`: what every gear and mesh takes unless it says otherwise.
    Defaults [material, pair] {}
}

keys! {
    /// `[[gear]]`.
    GearEntry [gear, material] {
        pub name: Option<String>,
        pub body: Option<String>,
    }
}

keys! {
    /// A gear declared inline on its body: it takes the body's name.
    InlineGear [gear, material] {}
}

keys! {
    /// `[[body]]`.
    BodyEntry [body, orbit] {
        pub name: Option<String>,
        pub gear: Option<Spanned<InlineGear>>,
    }
}

keys! {
    /// `[[mesh]]`.
    MeshEntry [pair, placed] {
        pub name: Option<String>,
        pub gears: Option<Vec<String>>,
    }
}

keys! {
    /// The per-pair keys a `[[planetary]]` gives all its sun or ring meshes.
    SetMeshes [pair] {}
}

keys! {
    /// `[[shaft]]`.
    ShaftEntry [] {
        pub name: Option<String>,
        pub bodies: Option<Vec<String>>,
        pub k: Option<f64>,
        pub d: Option<f64>,
        pub twist_start: Option<f64>,
    }
}

keys! {
    /// A sun or ring of a `[[planetary]]`: gear and body data inline.
    Member [gear, material, body] {
        pub fixed: Option<bool>,
    }
}

keys! {
    /// The planets of a `[[planetary]]`: one gear and body description for all.
    PlanetMember [gear, material, body] {}
}

keys! {
    /// The carrier of a `[[planetary]]`.
    CarrierMember [body] {}
}

keys! {
    /// `[[planetary]]`: a simple planetary set.
    Planetary [] {
        pub name: Option<String>,
        pub sun: Option<Spanned<Member>>,
        pub planet: Option<Spanned<PlanetMember>>,
        pub ring: Option<Spanned<Member>>,
        pub carrier: Option<Spanned<CarrierMember>>,
        pub planets: Option<i64>,
        pub orbit_angles: Option<Vec<f64>>,
        pub orbit_angles_deg: Option<Vec<f64>>,
        pub planet_pin_errors: Option<Vec<Vec<f64>>>,
        pub sun_meshes: Option<Spanned<SetMeshes>>,
        pub ring_meshes: Option<Spanned<SetMeshes>>,
    }
}

keys! {
    /// A mesh in the paper's own geometry (gear-mesh-model.md §1).
    Paper [] {
        #[serde(rename = "zA_nominal")]
        pub z_a_nominal: Option<i64>,
        #[serde(rename = "zB_nominal")]
        pub z_b_nominal: Option<i64>,
        #[serde(rename = "rA")]
        pub r_a: Option<f64>,
        pub alpha_factor: Option<f64>,
    }
}

keys! {
    /// `[solver]`.
    SolverEntry [] {
        pub solver: Option<i64>,
        pub rel_tol: Option<f64>,
        pub statistics: Option<bool>,
        pub stats_start: Option<f64>,
    }
}
