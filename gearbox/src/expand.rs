//! From the file as read (`file.rs`) to the description (`description.rs`): defaults applied,
//! inline gears and planetary sets expanded, names resolved, and what the file alone shows to
//! be wrong refused with the element's name and line.

use crate::description::{
    extent, line_of, Body, Damping, Deviations, Drive, Gear, Gearbox, Lateral, Mesh, Orbit,
    PaperGeometry, Ripple, Shaft, Solver, Support,
};
use crate::file::{
    BodyEntry, Defaults, File, GearEntry, MeshEntry, Planetary, SetMeshes, ShaftEntry,
};
use crate::Refusal;
use std::f64::consts::PI;
use std::ops::Range;
use toml::Spanned;

/// The reference pressure angle when neither a gear nor `[defaults]` gives one (ISO 53).
pub const PRESSURE_ANGLE_DEFAULT: f64 = 20.0 * PI / 180.0;

type R<T> = Result<T, Refusal>;

/// An angle given in radians or, under `KEY_deg`, in degrees; not both.
fn angle(rad: Option<f64>, deg: Option<f64>, err: impl Fn(String) -> Refusal) -> R<Option<f64>> {
    match (rad, deg) {
        (Some(_), Some(_)) => Err(err(
            "give the angle in radians or in degrees, not both".into()
        )),
        (r, d) => Ok(r.or(d.map(f64::to_radians))),
    }
}

/// A `Gear` from any table with a gear's keys (`[[gear]]`, an inline gear, a planetary member).
macro_rules! gear_of {
    ($b:expr, $e:expr, $name:expr, $support:expr) => {{
        let (b, e, name): (&mut Builder, _, String) = ($b, $e, $name);
        let d = b.defaults;
        let err = |key: &str, what: String| b.refuse("gear", &name, key, &what);
        let z =
            e.z.ok_or_else(|| err("z", "z (the number of teeth) is required".into()))?;
        Gear {
            support: $support,
            z,
            x: e.x.unwrap_or(0.0),
            internal: e.internal.unwrap_or(false),
            module: e.module.or(d.module),
            pressure_angle: angle(
                e.pressure_angle.or(d.pressure_angle),
                e.pressure_angle_deg.or(d.pressure_angle_deg),
                |w| err("pressure_angle", w),
            )?,
            width: e.width.or(d.width),
            addendum: e.addendum.or(d.addendum),
            tip_diameter: e.tip_diameter,
            e: e.e.or(d.e),
            nu: e.nu.or(d.nu),
            mount: angle(e.mount, e.mount_deg, |w| err("mount", w))?,
            dedendum: e.dedendum.or(d.dedendum),
            rack_tip_radius: e.rack_tip_radius.or(d.rack_tip_radius),
            bore_radius: e.bore_radius,
            deviations: Deviations {
                tip_relief: e.tip_relief,
                tip_relief_length: e.tip_relief_length,
                ecc: e.ecc,
                ecc_phase: angle(e.ecc_phase, e.ecc_phase_deg, |w| err("ecc_phase", w))?,
            },
            pitch_errors: e.pitch_errors.clone().unwrap_or_default(),
            name,
        }
    }};
}

/// A `Body` from any table with a body's keys; the orbit is set by the caller.
macro_rules! body_of {
    ($b:expr, $e:expr, $name:expr) => {{
        let (b, e, name): (&Builder, _, String) = ($b, $e, $name);
        let err = |key: &str, what: String| b.refuse("body", &name, key, &what);
        let drive = match e.drive.as_deref() {
            None | Some("torque") => Drive::Torque,
            Some("speed") => Drive::Speed,
            Some(other) => {
                return Err(err(
                    "drive",
                    format!("drive = \"{other}\": must be \"torque\" or \"speed\""),
                ))
            }
        };
        Body {
            j: e.j
                .ok_or_else(|| err("J", "J (its moment of inertia, kg.m2) is required".into()))?,
            m: e.m,
            c: e.c,
            tau: e.tau,
            w_start: e.w_start,
            angle_start: e.angle_start,
            drive,
            orbit: None,
            ripple: Ripple {
                tau_ripple: e.tau_ripple,
                ripple_order: e.ripple_order,
                ripple_phase: e.ripple_phase,
            },
            lateral: Lateral {
                lateral: e.lateral.unwrap_or(false),
                k_x: e.k_x,
                k_y: e.k_y,
                c_x: e.c_x,
                c_y: e.c_y,
                x_start: e.x_start,
                y_start: e.y_start,
                vx_start: e.vx_start,
                vy_start: e.vy_start,
            },
            name,
        }
    }};
}

/// The per-pair keys of a mesh (`[[mesh]]` or a planetary set's), each over `[defaults]`.
macro_rules! pair_of {
    ($b:expr, $e:expr, $name:expr, $gears:expr) => {{
        let (b, e, name): (&Builder, _, String) = ($b, $e, $name);
        let d = b.defaults;
        let damping = match (e.chi, e.damping_ratio) {
            (Some(_), Some(_)) => {
                return Err(b.refuse("mesh", &name, "chi", "give chi or damping_ratio, not both"))
            }
            (Some(c), None) => Some(Damping::Chi(c)),
            (None, Some(r)) => Some(Damping::Ratio(r)),
            (None, None) => match (d.chi, d.damping_ratio) {
                (Some(_), Some(_)) => {
                    return Err(Refusal(
                        "[defaults]: give chi or damping_ratio, not both".into(),
                    ))
                }
                (c, r) => c.map(Damping::Chi).or(r.map(Damping::Ratio)),
            },
        };
        Mesh {
            gears: $gears,
            backlash: e.backlash.or(d.backlash),
            damping,
            mu: e.mu.or(d.mu),
            v_reg: e.v_reg.or(d.v_reg),
            contact_model: e.contact_model.or(d.contact_model),
            contacts_per_flank: e.contacts_per_flank.or(d.contacts_per_flank),
            backward_contacts: e.backward_contacts.or(d.backward_contacts),
            tip_relief_shape: e.tip_relief_shape.or(d.tip_relief_shape),
            k_lumped: e.k_lumped.or(d.k_lumped),
            c_lumped: e.c_lumped.or(d.c_lumped),
            k_lumped_varies: e.k_lumped_varies.or(d.k_lumped_varies),
            name,
            ..Mesh::default()
        }
    }};
}

struct Builder<'a> {
    text: &'a str,
    defaults: &'a Defaults,
    g: Gearbox,
}

/// Something of the file that declares bodies or meshes, in the file's order.
enum Item<'a> {
    Set(&'a Spanned<Planetary>),
    Body(&'a Spanned<BodyEntry>),
    Mesh(&'a Spanned<MeshEntry>),
}

impl Item<'_> {
    fn start(&self) -> usize {
        match self {
            Item::Set(s) => s.span().start,
            Item::Body(s) => s.span().start,
            Item::Mesh(s) => s.span().start,
        }
    }
}

/// The gears of a planetary set, for its meshes.
struct SetGears {
    sun: usize,
    planets: Vec<usize>,
    ring: usize,
}

impl<'a> Builder<'a> {
    fn refuse(&self, kind: &str, name: &str, key: &str, what: &str) -> Refusal {
        Refusal(self.g.at(kind, name, key, what))
    }

    /// An element of `kind` without a name: "body 3 (line 40)".
    fn nameless(&self, kind: &str, k: usize, span: &Range<usize>) -> Refusal {
        Refusal(format!(
            "[[{kind}]] number {} (line {}): name is required",
            k + 1,
            line_of(self.text, span.start)
        ))
    }

    /// Records where a named element stands; names are unique (a gear may share its body's).
    fn place(&mut self, kind: &str, name: &str, span: Range<usize>) -> R<()> {
        let ident = |s: &str| {
            let mut c = s.chars();
            matches!(c.next(), Some(ch) if ch.is_ascii_alphabetic() || ch == '_')
                && c.all(|ch| ch.is_ascii_alphanumeric() || ch == '_')
        };
        let key = format!("{kind}:{name}");
        self.g.lines.element.insert(key, extent(self.text, span));
        let line = self.g.lines.of(kind, name, "name").unwrap_or(0);
        if !name.split('.').all(ident) || name == "housing" {
            return Err(Refusal(format!(
                "{kind} \"{name}\": a name is an identifier ([A-Za-z_][A-Za-z0-9_]*, parts joined by '.'), and not \"housing\" (line {line})"
            )));
        }
        let taken = match kind {
            "gear" => self.g.gears.iter().any(|g| g.name == name),
            _ => {
                self.g.bodies.iter().any(|b| b.name == name)
                    || self.g.meshes.iter().any(|m| m.name == name)
                    || self.g.shafts.iter().any(|s| s.name == name)
            }
        };
        if taken {
            return Err(Refusal(format!(
                "{kind} {name}: the name is already taken (line {line})"
            )));
        }
        Ok(())
    }

    fn body_index(&self, name: &str) -> Option<usize> {
        self.g.bodies.iter().position(|b| b.name == name)
    }

    /// A shaft's or gear's support by name.
    fn support(&self, name: &str) -> Option<Support> {
        if name == "housing" {
            Some(Support::Housing)
        } else {
            self.body_index(name).map(Support::Body)
        }
    }

    fn add_body(&mut self, k: usize, e: &Spanned<BodyEntry>) -> R<()> {
        let name = e
            .get_ref()
            .name
            .clone()
            .ok_or_else(|| self.nameless("body", k, &e.span()))?;
        self.place("body", &name, e.span())?;
        let mut body = body_of!(self, e.get_ref(), name.clone());
        let en = e.get_ref();
        let orbit_angle = angle(en.orbit_angle, en.orbit_angle_deg, |w| {
            self.refuse("body", &name, "orbit_angle", &w)
        })?;
        if let Some(c) = &en.carrier {
            let carrier = self.body_index(c).ok_or_else(|| {
                self.refuse(
                    "body",
                    &name,
                    "carrier",
                    &format!("carrier = \"{c}\": no body of that name is declared before it"),
                )
            })?;
            body.orbit = Some(Orbit {
                carrier,
                angle: orbit_angle.unwrap_or(0.0),
                pin_error_r: en.pin_error_r,
                pin_error_t: en.pin_error_t,
            });
        } else if let Some(key) = [
            ("orbit_angle", orbit_angle.is_some()),
            ("pin_error_r", en.pin_error_r.is_some()),
            ("pin_error_t", en.pin_error_t.is_some()),
        ]
        .iter()
        .find_map(|&(k, set)| set.then_some(k))
        {
            return Err(self.refuse("body", &name, key, &format!("{key} needs a carrier")));
        }
        self.g.bodies.push(body);
        if let Some(gear) = &en.gear {
            self.place("gear", &name, gear.span())?;
            let i = self.g.bodies.len() - 1;
            let gear = gear_of!(self, gear.get_ref(), name, Support::Body(i));
            self.g.gears.push(gear);
        }
        Ok(())
    }

    /// A planetary set's bodies and gears: sun, carrier, planets, ring (gearbox-file.md §1).
    fn add_set(&mut self, k: usize, s: &Spanned<Planetary>) -> R<SetGears> {
        let set = s.get_ref();
        let name = set
            .name
            .clone()
            .ok_or_else(|| self.nameless("planetary", k, &s.span()))?;
        self.place("planetary", &name, s.span())?;
        let missing = |what: &str| {
            self.refuse(
                "planetary",
                &name,
                what,
                &format!("{what} = {{ ... }} is required"),
            )
        };
        let (sun, planet, ring, carrier) = (
            set.sun.as_ref().ok_or_else(|| missing("sun"))?,
            set.planet.as_ref().ok_or_else(|| missing("planet"))?,
            set.ring.as_ref().ok_or_else(|| missing("ring"))?,
            set.carrier.as_ref().ok_or_else(|| missing("carrier"))?,
        );
        let orbit_angles = match (set.planets, &set.orbit_angles, &set.orbit_angles_deg) {
            (Some(n), None, None) if n >= 1 => {
                (0..n).map(|k| 2.0 * PI * k as f64 / n as f64).collect()
            }
            (None, Some(a), None) if !a.is_empty() => a.clone(),
            (None, None, Some(a)) if !a.is_empty() => a.iter().map(|x| x.to_radians()).collect(),
            _ => {
                return Err(self.refuse(
                    "planetary",
                    &name,
                    "planets",
                    "give the planets as planets = N (equally spaced, N >= 1), orbit_angles or orbit_angles_deg: one of them",
                ))
            }
        };
        let errors = set.planet_pin_errors.clone().unwrap_or_default();
        if !errors.is_empty()
            && (errors.len() != orbit_angles.len() || errors.iter().any(|e| e.len() != 2))
        {
            return Err(self.refuse(
                "planetary",
                &name,
                "planet_pin_errors",
                &format!(
                    "planet_pin_errors needs one [radial, tangential] pair per planet ({} planets)",
                    orbit_angles.len()
                ),
            ));
        }
        if sun.get_ref().fixed == Some(true) && ring.get_ref().fixed == Some(true) {
            return Err(self.refuse(
                "planetary",
                &name,
                "ring",
                "the sun and the ring cannot both be fixed",
            ));
        }
        let sun = self.add_member(&name, "sun", sun, false)?;
        let c_name = format!("{name}.carrier");
        self.place("body", &c_name, carrier.span())?;
        let c_body = body_of!(self, carrier.get_ref(), c_name);
        self.g.bodies.push(c_body);
        let c_index = self.g.bodies.len() - 1;
        let mut planets = Vec::with_capacity(orbit_angles.len());
        for (k, &angle) in orbit_angles.iter().enumerate() {
            let p_name = format!("{name}.planet{}", k + 1);
            self.place("body", &p_name, planet.span())?;
            let mut body = body_of!(self, planet.get_ref(), p_name.clone());
            body.orbit = Some(Orbit {
                carrier: c_index,
                angle,
                pin_error_r: errors.get(k).map(|e| e[0]),
                pin_error_t: errors.get(k).map(|e| e[1]),
            });
            self.g.bodies.push(body);
            self.place("gear", &p_name, planet.span())?;
            let i = self.g.bodies.len() - 1;
            let gear = gear_of!(self, planet.get_ref(), p_name, Support::Body(i));
            if gear.internal {
                return Err(self.refuse("gear", &gear.name, "internal", "a planet is external"));
            }
            self.g.gears.push(gear);
            planets.push(self.g.gears.len() - 1);
        }
        let ring = self.add_member(&name, "ring", ring, true)?;
        Ok(SetGears { sun, planets, ring })
    }

    /// A set's sun or ring: a body of its own, or a gear in the housing when fixed.
    fn add_member(
        &mut self,
        set: &str,
        part: &str,
        m: &Spanned<crate::file::Member>,
        internal: bool,
    ) -> R<usize> {
        let name = format!("{set}.{part}");
        let e = m.get_ref();
        let support = if e.fixed == Some(true) {
            let body_key = [
                ("J", e.j.is_some()),
                ("c", e.c.is_some()),
                ("tau", e.tau.is_some()),
                ("w_start", e.w_start.is_some()),
                ("m", e.m.is_some()),
                ("drive", e.drive.is_some()),
                ("lateral", e.lateral.is_some()),
            ]
            .iter()
            .find_map(|&(k, set)| set.then_some(k));
            if let Some(key) = body_key {
                self.place("gear", &name, m.span())?;
                return Err(self.refuse(
                    "gear",
                    &name,
                    key,
                    &format!("{key}: a fixed {part} is part of the housing and has no body"),
                ));
            }
            Support::Housing
        } else {
            self.place("body", &name, m.span())?;
            let body = body_of!(self, e, name.clone());
            self.g.bodies.push(body);
            Support::Body(self.g.bodies.len() - 1)
        };
        self.place("gear", &name, m.span())?;
        let mut gear = gear_of!(self, e, name.clone(), support);
        match (e.internal, internal) {
            (Some(given), must) if given != must => {
                let what = if must {
                    "a ring is internal"
                } else {
                    "a sun is external"
                };
                return Err(self.refuse("gear", &name, "internal", what));
            }
            _ => gear.internal = internal,
        }
        self.g.gears.push(gear);
        Ok(self.g.gears.len() - 1)
    }

    fn add_gear(&mut self, k: usize, e: &Spanned<GearEntry>) -> R<()> {
        let name = e
            .get_ref()
            .name
            .clone()
            .ok_or_else(|| self.nameless("gear", k, &e.span()))?;
        self.place("gear", &name, e.span())?;
        let body = e.get_ref().body.as_deref().ok_or_else(|| {
            self.refuse(
                "gear",
                &name,
                "body",
                "body is required: the body it turns with, or \"housing\"",
            )
        })?;
        let support = self.support(body).ok_or_else(|| {
            self.refuse(
                "gear",
                &name,
                "body",
                &format!("body = \"{body}\": no such body"),
            )
        })?;
        if let Support::Body(i) = support {
            if self.g.bodies[i].name != name && self.g.bodies.iter().any(|b| b.name == name) {
                return Err(self.refuse(
                    "gear",
                    &name,
                    "name",
                    "a gear may share a name only with its own body",
                ));
            }
        }
        let gear = gear_of!(self, e.get_ref(), name, support);
        self.g.gears.push(gear);
        Ok(())
    }

    /// The two names a mesh's `gears` or a shaft's `bodies` must give.
    fn two(
        &self,
        kind: &str,
        k: usize,
        span: &Range<usize>,
        names: Option<&[String]>,
        what: &str,
    ) -> R<[String; 2]> {
        match names {
            Some([a, b]) => Ok([a.clone(), b.clone()]),
            _ => Err(Refusal(format!(
                "[[{kind}]] number {} (line {}): {what}",
                k + 1,
                line_of(self.text, span.start)
            ))),
        }
    }

    fn gear_index(&self, mesh: &str, gear: &str) -> R<usize> {
        self.g
            .gears
            .iter()
            .position(|g| g.name == gear)
            .ok_or_else(|| self.refuse("mesh", mesh, "gears", &format!("no gear named \"{gear}\"")))
    }

    fn add_mesh(&mut self, k: usize, e: &Spanned<MeshEntry>) -> R<()> {
        let en = e.get_ref();
        let gears = self.two(
            "mesh",
            k,
            &e.span(),
            en.gears.as_deref(),
            "gears = [\"A\", \"B\"] names its two gears",
        )?;
        let name = en
            .name
            .clone()
            .unwrap_or_else(|| format!("{}_{}", gears[0], gears[1]));
        self.place("mesh", &name, e.span())?;
        let ab = [
            self.gear_index(&name, &gears[0])?,
            self.gear_index(&name, &gears[1])?,
        ];
        let mut mesh = pair_of!(self, en, name.clone(), ab);
        mesh.center_angle = angle(en.center_angle, en.center_angle_deg, |w| {
            self.refuse("mesh", &name, "center_angle", &w)
        })?;
        mesh.center_distance_error = en.center_distance_error;
        mesh.dte_start = en.dte_start;
        if let Some(p) = &en.paper {
            let need = |key: &str| {
                self.refuse(
                    "mesh",
                    &name,
                    "paper",
                    &format!("paper = {{ ... }} needs {key}"),
                )
            };
            mesh.paper = Some(PaperGeometry {
                z_a_nominal: p.z_a_nominal.ok_or_else(|| need("zA_nominal"))?,
                z_b_nominal: p.z_b_nominal.ok_or_else(|| need("zB_nominal"))?,
                r_a: p.r_a.ok_or_else(|| need("rA"))?,
                alpha_factor: p.alpha_factor.ok_or_else(|| need("alpha_factor"))?,
            });
        }
        self.push_mesh(mesh)
    }

    fn add_set_meshes(&mut self, s: &Spanned<Planetary>, gears: &SetGears) -> R<()> {
        let set = s.get_ref().name.clone().unwrap_or_default();
        let none = SetMeshes::default();
        fn pairs<'k>(
            m: &'k Option<Spanned<SetMeshes>>,
            none: &'k SetMeshes,
            set: Range<usize>,
        ) -> (&'k SetMeshes, Range<usize>) {
            m.as_ref().map_or((none, set), |m| (m.get_ref(), m.span()))
        }
        let (sun_keys, sun_span) = pairs(&s.get_ref().sun_meshes, &none, s.span());
        let (ring_keys, ring_span) = pairs(&s.get_ref().ring_meshes, &none, s.span());
        for (k, &p) in gears.planets.iter().enumerate() {
            let name = format!("{set}.sun_planet{}", k + 1);
            self.place("mesh", &name, sun_span.clone())?;
            let mesh = pair_of!(self, sun_keys, name, [gears.sun, p]);
            self.push_mesh(mesh)?;
        }
        for (k, &p) in gears.planets.iter().enumerate() {
            let name = format!("{set}.planet{}_ring", k + 1);
            self.place("mesh", &name, ring_span.clone())?;
            let mesh = pair_of!(self, ring_keys, name, [p, gears.ring]);
            self.push_mesh(mesh)?;
        }
        Ok(())
    }

    /// Checks what a mesh's two gears must share, then adds it.
    fn push_mesh(&mut self, mesh: Mesh) -> R<()> {
        let [a, b] = mesh.gears.map(|g| &self.g.gears[g]);
        let err = |what: String| self.refuse("mesh", &mesh.name, "gears", &what);
        if a.internal && b.internal {
            return Err(err(format!(
                "gears {} and {} are both internal: two ring gears cannot mesh",
                a.name, b.name
            )));
        }
        if a.internal {
            return Err(err(format!(
                "gear {} is internal: an internal gear is always B (gears = [\"{}\", \"{}\"])",
                a.name, b.name, a.name
            )));
        }
        if a.support == b.support {
            return Err(err(format!(
                "gears {} and {} turn with the same body",
                a.name, b.name
            )));
        }
        if mesh.paper.is_none() {
            for g in [a, b] {
                match g.module {
                    None => {
                        return Err(self.refuse(
                            "gear",
                            &g.name,
                            "module",
                            "module is required (here or in [defaults])",
                        ))
                    }
                    Some(m) if !(m > 0.0 && m.is_finite()) => {
                        return Err(self.refuse(
                            "gear",
                            &g.name,
                            "module",
                            &format!("module = {m}: must be a positive length [m]"),
                        ))
                    }
                    Some(_) => {}
                }
            }
            let alpha = |g: &Gear| g.pressure_angle.unwrap_or(PRESSURE_ANGLE_DEFAULT);
            let same = |x: f64, y: f64| (x - y).abs() <= 1e-12 * x.abs().max(y.abs());
            if !same(a.module.unwrap(), b.module.unwrap()) || !same(alpha(a), alpha(b)) {
                return Err(err(format!(
                    "gear {} (module {} m, pressure angle {} deg) cannot mesh with gear {} (module {} m, pressure angle {} deg): the gears of a mesh share module and pressure angle",
                    a.name,
                    a.module.unwrap(),
                    alpha(a).to_degrees(),
                    b.name,
                    b.module.unwrap(),
                    alpha(b).to_degrees()
                )));
            }
        }
        self.g.meshes.push(mesh);
        Ok(())
    }

    fn add_shaft(&mut self, k: usize, e: &Spanned<ShaftEntry>) -> R<()> {
        let en = e.get_ref();
        let ends = self.two(
            "shaft",
            k,
            &e.span(),
            en.bodies.as_deref(),
            "bodies = [\"a\", \"b\"] names its two ends (a body, or \"housing\")",
        )?;
        let name = en
            .name
            .clone()
            .unwrap_or_else(|| format!("{}_{}", ends[0], ends[1]));
        self.place("shaft", &name, e.span())?;
        let support = |end: &str| {
            self.support(end).ok_or_else(|| {
                self.refuse(
                    "shaft",
                    &name,
                    "bodies",
                    &format!("no body named \"{end}\""),
                )
            })
        };
        let ends = [support(&ends[0])?, support(&ends[1])?];
        let k = en.k.ok_or_else(|| {
            self.refuse(
                "shaft",
                &name,
                "k",
                "k (its torsional stiffness, N.m/rad) is required",
            )
        })?;
        self.g.shafts.push(Shaft {
            name,
            ends,
            k,
            d: en.d,
            twist_start: en.twist_start,
        });
        Ok(())
    }
}

/// The description of a file already read.
pub fn expand(text: &str, f: &File) -> R<Gearbox> {
    let mut b = Builder {
        text,
        defaults: &f.defaults,
        g: Gearbox {
            name: f.name.clone(),
            description: f.description.clone().unwrap_or_default(),
            static_start: f.static_start.unwrap_or(true),
            ..Gearbox::default()
        },
    };
    b.g.lines.text = text.to_owned();
    let mut items: Vec<(usize, Item)> = f
        .planetary
        .iter()
        .enumerate()
        .map(|(k, s)| (k, Item::Set(s)))
        .collect();
    items.extend(f.body.iter().enumerate().map(|(k, e)| (k, Item::Body(e))));
    items.extend(f.mesh.iter().enumerate().map(|(k, e)| (k, Item::Mesh(e))));
    items.sort_by_key(|(_, i)| i.start());
    // Bodies first (a gear or mesh may name a body declared after it), then the gears, then
    // the meshes, each in the file's order.
    let mut sets = Vec::new();
    for (k, item) in &items {
        match item {
            Item::Set(s) => sets.push(b.add_set(*k, s)?),
            Item::Body(e) => b.add_body(*k, e)?,
            Item::Mesh(_) => {}
        }
    }
    for (k, e) in f.gear.iter().enumerate() {
        b.add_gear(k, e)?;
    }
    let mut sets = sets.into_iter();
    for (k, item) in &items {
        match item {
            Item::Set(s) => b.add_set_meshes(s, &sets.next().expect("one per set"))?,
            Item::Mesh(e) => b.add_mesh(*k, e)?,
            Item::Body(_) => {}
        }
    }
    for (k, e) in f.shaft.iter().enumerate() {
        b.add_shaft(k, e)?;
    }
    if let Some(i) =
        b.g.bodies
            .iter()
            .skip(1)
            .position(|x| x.angle_start.is_some())
    {
        let name = b.g.bodies[i + 1].name.clone();
        return Err(b.refuse(
            "body",
            &name,
            "angle_start",
            "angle_start belongs to the first body the file declares, which places the others",
        ));
    }
    let s = &f.solver;
    b.g.solver = Solver {
        solver: s.solver,
        rel_tol: s.rel_tol,
        statistics: s.statistics,
        stats_start: s.stats_start,
    };
    Ok(b.g)
}
