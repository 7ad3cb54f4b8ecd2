//! The variable table, generated from `modelDescription/variables.toml` by build.rs: `Var` with
//! its value references, and the structs `Params`, `Inputs`, `Outputs`, `Calculated`.
// Generated: ranges are literal values (pi/2 among them) and a getter of a struct with one
// field of a type is a one-armed match.
#![allow(clippy::approx_constant, clippy::match_single_binding)]
include!(concat!(env!("OUT_DIR"), "/variables.rs"));

/// The modelDescription.xml generated from the same table (the packaging step writes the same text).
pub const MODEL_DESCRIPTION_XML: &str =
    include_str!(concat!(env!("OUT_DIR"), "/modelDescription.xml"));

impl Outputs {
    /// One mesh's outputs (the per-pair ones a gear train also shows per mesh) from its
    /// readout and statistics.
    #[inline]
    pub fn set_mesh(
        &mut self,
        r: &crate::model::mesh::MeshReadout,
        run: &crate::model::statistics::Summary,
    ) {
        // Field by field: a struct literal here was built aside and copied.
        self.F_f1 = r.pair_force[0];
        self.F_f2 = r.pair_force[1];
        self.F_b1 = r.pair_force[2];
        self.F_b2 = r.pair_force[3];
        self.F_fwd = r.flank_force[0];
        self.F_bwd = r.flank_force[1];
        self.n_fwd = r.flank_pairs[0] as i32;
        self.n_bwd = r.flank_pairs[1] as i32;
        self.tau_mesh_A = r.tq_a;
        self.tau_mesh_B = r.tq_b;
        self.s_f1 = r.contact_point[0];
        self.s_f2 = r.contact_point[1];
        self.s_b1 = r.contact_point[2];
        self.s_b2 = r.contact_point[3];
        self.F_B_x = r.force_on_b[0];
        self.F_B_y = r.force_on_b[1];
        self.k_mesh = r.k_mesh;
        self.load_share = if r.flank_force[0] != 0.0 {
            r.pair_force[0] / r.flank_force[0]
        } else {
            0.0
        };
        self.dte_mean = run.dte_mean;
        self.dte_rms = run.dte_rms;
        self.dte_min = run.dte_min;
        self.dte_max = run.dte_max;
        self.F_max = run.f_max;
        self.t_separated = run.t_separated;
        self.t_backward = run.t_backward;
    }
}

impl Calculated {
    /// One pair's geometry.
    pub fn of_geometry(g: &crate::model::geometry::Geometry) -> Calculated {
        Calculated {
            alpha_w: g.alpha_w,
            rAb: g.r_ab,
            rBb: g.r_bb,
            line_of_action: g.l,
            s_a: g.s_a,
            s_b: g.s_b,
            contact_ratio: g.eps,
            r_tipA: g.r_tip_a,
            r_tipB: g.r_tip_b,
            base_pitch: g.p_b,
            contact_objects_per_flank: g.m_c as i32,
            center_distance: g.d,
            backlash_actual: g.j_n,
        }
    }
}
