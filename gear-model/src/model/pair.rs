//! The plain description of one gear pair, which every model is built from: its two gears,
//! how they were cut, and how their teeth meet. The FMI parameter tables (`crate::table`) and
//! the gearbox file (crate `gearbox`, through SpurGearTrain's table) both produce it, so the
//! physics does not depend on how a master names or stores the numbers.
//!
//! Messages still name a pair's numbers as SpurGearMesh does (`zA`, `xB`, `backlash`): a
//! train prefixes them with its mesh, and the gearbox FMU translates them into the file's names.

/// One gear of a pair, as declared once on its body.
#[derive(Clone, Debug, PartialEq)]
pub struct Gear {
    /// Real tooth count.
    pub z: i32,
    /// Profile shift coefficient (standard cut).
    pub x: f64,
    /// Young's modulus \[Pa\] and Poisson ratio.
    pub e: f64,
    pub nu: f64,
    /// Bore radius (contact law 3; 0: half the root radius) \[m\].
    pub bore_radius: f64,
    /// Tip relief: amount and roll length along the line of action \[m\] (0: none).
    pub tip_relief: f64,
    pub tip_relief_length: f64,
    /// Runout: eccentricity of the base circle's centre \[m\] and its phase at angle 0 \[rad\].
    pub ecc: f64,
    pub ecc_phase: f64,
    /// Pitch deviation of each tooth along the line of action \[m\], tooth 0 first; empty: none.
    pub pitch_errors: Vec<f64>,
}

/// The paper's geometry (gear-mesh-model.md §2): nominal tooth counts, A's operating pitch
/// radius and alpha_w as a multiple of alpha_inf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperCut {
    pub z_nominal: [i32; 2],
    pub r_a: f64,
    pub alpha_factor: f64,
}

/// The ISO 53 basic rack that cut both gears (standard gear data).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rack {
    /// Module \[m\] and reference pressure angle \[rad\].
    pub module: f64,
    pub pressure_angle: f64,
    /// Addendum and dedendum coefficients, and the rack's tip radius coefficient rho_fP.
    pub addendum: f64,
    pub dedendum: f64,
    pub tip_radius: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cut {
    Paper(PaperCut),
    Standard(Rack),
}

/// How the teeth meet: the paper's Johnson compliance, rigid contact with impacts, the
/// tooth structure in series with the local contact, or the classical lumped spring.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MeshLaw {
    Johnson,
    Rigid,
    ToothStructure,
    Lumped(Lumped),
}

/// The lumped-parameter mesh of Kahraman & Singh and Lin & Parker (lateral.md §4): one linear
/// spring-damper along each flank's line of action, the teeth not tracked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lumped {
    /// Mean mesh stiffness \[N/m\] and viscous damping \[N.s/m\].
    pub k: f64,
    pub c: f64,
    /// The classical square wave: k n / eps with n the pairs on the contact segment.
    pub varies: bool,
}

/// The tip relief's shape (both gears).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReliefShape {
    Linear,
    Parabolic,
}

/// One gear pair.
#[derive(Clone, Debug, PartialEq)]
pub struct Pair {
    pub a: Gear,
    pub b: Gear,
    pub cut: Cut,
    /// Face width \[m\].
    pub width: f64,
    /// Normal backlash at the nominal centre distance \[m\].
    pub backlash: f64,
    /// B is a ring with internal teeth (standard cut only).
    pub internal: bool,
    /// The axes are this much further apart than nominal \[m\].
    pub center_distance_error: f64,
    pub law: MeshLaw,
    /// Newton's coefficient of restitution of rigid contact.
    pub restitution: f64,
    /// Hunt–Crossley damping factor \[s/m\], friction coefficient, friction's regularization
    /// velocity \[m/s\].
    pub chi: f64,
    pub mu: f64,
    pub v_reg: f64,
    pub relief_shape: ReliefShape,
    /// Contact objects per flank; 0: as many as the contact ratio needs.
    pub contacts_per_flank: usize,
    /// Whether the backward flank's objects are evaluated.
    pub backward_contacts: bool,
}

impl Pair {
    /// The basic rack of a standard cut.
    pub fn rack(&self) -> Option<&Rack> {
        match &self.cut {
            Cut::Standard(r) => Some(r),
            Cut::Paper(_) => None,
        }
    }
}

impl Gear {
    /// A steel gear of z teeth, unshifted, without deviations.
    pub fn steel(z: i32) -> Gear {
        Gear {
            z,
            x: 0.0,
            e: 2.1e11,
            nu: 0.3,
            bore_radius: 0.0,
            tip_relief: 0.0,
            tip_relief_length: 0.0,
            ecc: 0.0,
            ecc_phase: 0.0,
            pitch_errors: Vec::new(),
        }
    }
}

impl Rack {
    /// ISO 53 profile A: 20 degrees, addendum 1, dedendum 1.25, tip radius 0.38.
    pub fn iso53(module: f64) -> Rack {
        Rack {
            module,
            pressure_angle: 20f64.to_radians(),
            addendum: 1.0,
            dedendum: 1.25,
            tip_radius: 0.38,
        }
    }
}

impl Pair {
    /// The paper's pair (gear-mesh-model.md §5): 22/33 steel teeth on the nominal 20/30 pair,
    /// rA = 0.2 m, alpha_w = 2.8 alpha_inf, 20 mm wide, 0.1 mm backlash, Johnson's law with
    /// chi = 10 s/m, no friction. SpurGearMesh's defaults are these (`crate::table` checks it).
    pub fn paper() -> Pair {
        Pair {
            a: Gear::steel(22),
            b: Gear::steel(33),
            cut: Cut::Paper(PaperCut {
                z_nominal: [20, 30],
                r_a: 0.2,
                alpha_factor: 2.8,
            }),
            width: 0.02,
            backlash: 1e-4,
            internal: false,
            center_distance_error: 0.0,
            law: MeshLaw::Johnson,
            restitution: 0.0,
            chi: 10.0,
            mu: 0.0,
            v_reg: 0.01,
            relief_shape: ReliefShape::Linear,
            contacts_per_flank: 0,
            backward_contacts: true,
        }
    }

    /// The paper's pair cut instead by an ISO 53 rack of module 10 mm (SpurGearMesh with
    /// `geometry = 2`).
    pub fn standard() -> Pair {
        Pair {
            cut: Cut::Standard(Rack::iso53(0.01)),
            ..Pair::paper()
        }
    }
}
