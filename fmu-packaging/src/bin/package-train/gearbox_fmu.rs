//! `package-train --gearbox FILE`: the FMU of one gearbox (gearbox-file.md §2). Its binary is
//! SpurGearTrain's; its modelDescription.xml declares the gearbox's variables
//! (`spur_gear_train::gearbox_vars`) with SpurGearTrain's types, units, ranges and
//! descriptions, and start values read from an instance of the FMU made from the same file, so
//! the description and the binary cannot disagree.

use fmi2_slave::Slave;
use model_description::{model_description_xml, model_description_xml3, Table, Var};
use spur_gear_train::fmu::{guid_source, GearboxFmu, TrainFmu, RESOURCE, VERSION};
use spur_gear_train::gearbox_vars::{GearKey, Target};
use spur_gear_train::variables::{Causality, VarType};
use std::sync::Arc;

/// Writes `NAME.fmu` and `NAME-fmi3.fmu`; returns the FMI 2.0 one's path. A refused file ends
/// the process with its message.
pub fn package(path: &str, train: &Table) -> std::path::PathBuf {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| {
        eprintln!("package-train: {path}: {e}");
        std::process::exit(1)
    });
    let fmu = GearboxFmu::new(&text).unwrap_or_else(|e| {
        eprintln!("package-train: {path}: {e}");
        std::process::exit(1)
    });
    let fmu = Arc::new(fmu);
    let table = table(&fmu, &text, train);
    let name = fmu.gearbox.name.clone();
    let so = fmu_packaging::release_binary("spur_gear_train");
    let dll = fmu_packaging::windows_binary("spur_gear_train");
    let doc = documentation(&fmu, &table);
    let layout = super::layout::svg(&fmu.gearbox);
    let resource = format!("resources/{RESOURCE}");
    let mut out = None;
    for (fmi3, xml) in [
        (false, model_description_xml(&table, VERSION)),
        (true, model_description_xml3(&table, VERSION)),
    ] {
        let (linux, windows) = if fmi3 {
            ("x86_64-linux", "x86_64-windows")
        } else {
            ("linux64", "win64")
        };
        let so_name = format!("binaries/{linux}/{name}.so");
        let dll_name = format!("binaries/{windows}/{name}.dll");
        let mut files: Vec<(&str, &[u8])> = vec![
            ("modelDescription.xml", xml.as_bytes()),
            (&so_name, &so),
            (&resource, text.as_bytes()),
            ("documentation/index.html", doc.as_bytes()),
            ("documentation/layout.svg", layout.as_bytes()),
        ];
        if let Some(dll) = &dll {
            files.push((&dll_name, dll));
        }
        let model = if fmi3 {
            format!("{name}-fmi3")
        } else {
            name.clone()
        };
        let p = fmu_packaging::write_fmu(&model, &files);
        if fmi3 {
            eprintln!("FMI 3.0: {}", p.display());
        } else {
            out = Some(p);
        }
    }
    out.expect("the FMI 2.0 FMU")
}

/// The gearbox's table: its variables with SpurGearTrain's attributes, its own names and value
/// references, and the start values of a fresh instance.
fn table(fmu: &Arc<GearboxFmu>, text: &str, train: &Table) -> Table {
    let g = &fmu.gearbox;
    let mut instance = TrainFmu::gearbox(fmu.clone());
    let mut vars = Vec::with_capacity(fmu.vars.len());
    for (k, v) in fmu.vars.iter().enumerate() {
        let info = v.train.info();
        let base = train
            .vars
            .iter()
            .find(|x| x.name == info.name)
            .expect("the table has every train variable");
        let vr = k as u32 + 1;
        let causality = match v.causality {
            Causality::Parameter => "parameter",
            Causality::CalculatedParameter => "calculatedParameter",
            Causality::Input => "input",
            Causality::Output => "output",
            Causality::Local => "local",
        };
        let start = matches!(v.causality, Causality::Parameter | Causality::Input).then(|| {
            let value = match info.ty {
                VarType::Real => instance.get_real(vr).map(toml::Value::Float),
                VarType::Integer => instance
                    .get_integer(vr)
                    .map(|x| toml::Value::Integer(x as i64)),
                VarType::Boolean => instance.get_boolean(vr).map(toml::Value::Boolean),
                VarType::String => instance.get_string(vr).map(toml::Value::String),
            };
            value.unwrap_or_else(|e| panic!("{}: {}", v.name, e.message))
        });
        let calculated = v.causality == Causality::CalculatedParameter;
        let mut var = Var {
            name: v.name.clone(),
            vr,
            causality: causality.into(),
            // A calculated parameter has no start value (initial = "calculated").
            start: start.or_else(|| base.start.clone().filter(|_| !calculated)),
            description: v
                .description
                .clone()
                .unwrap_or_else(|| base.description.clone()),
            ..base.clone()
        };
        if calculated {
            var.variability = "fixed".into();
        }
        if let Target::Gear {
            key: GearKey::TipDiameter,
            ..
        } = v.target
        {
            var.unit = Some("m".into());
            var.display_unit = Some("mm".into());
            (var.min, var.max, var.exclusive_min) = (Some(0.0), None, true);
        }
        vars.push(var);
    }
    let mut t = train.clone();
    t.vars = vars;
    t.text = guid_source(text);
    t.model.name = g.name.clone();
    if !g.description.is_empty() {
        t.model.description = format!(
            "{} (a gearbox of SpurGearTrain, from its gearbox file)",
            g.description
        );
    }
    if let Some(me) = &mut t.model.model_exchange {
        // The gearbox's table holds its own states only: it declares them all.
        me.declared_states = None;
        let per_mesh = me.event_indicators.len() / 16;
        me.event_indicators = g
            .meshes
            .iter()
            .enumerate()
            .flat_map(|(m, mesh)| {
                me.event_indicators[m * per_mesh..(m + 1) * per_mesh]
                    .iter()
                    .map(move |[name, what]| {
                        let own = format!("mesh[{}].", m + 1);
                        [
                            name.replacen(&own, &format!("{}.", mesh.name), 1),
                            what.replacen(
                                &format!("Mesh {}:", m + 1),
                                &format!("Mesh {}:", mesh.name),
                                1,
                            ),
                        ]
                    })
            })
            .collect();
        me.event_indicator_vr = fmu.vars.len() as u32 + 1;
    }
    t
}

/// documentation/index.html: what the FMU is, its layout, its interfaces and its variables.
fn documentation(fmu: &GearboxFmu, t: &Table) -> String {
    let g = &fmu.gearbox;
    let esc = fmu_packaging::esc;
    let mut h = fmu_packaging::html_head(&g.name);
    h.push_str(&format!(
        "<h1>{}</h1>\n<p>{}</p>\n",
        esc(&g.name),
        esc(&t.model.description)
    ));
    h.push_str(&format!(
        "<p>{} bodies, {} gears, {} meshes, {} shafts. The model is SpurGearTrain's (Kosenko &amp; Gusev 2012 per mesh: Johnson line-contact compliance, Hunt&ndash;Crossley damping, friction, backlash, contact ratio above one), built from the gearbox file in <code>resources/gearbox.toml</code>; the file's values are the start values below. Every angle, speed and torque is forward positive.</p>\n",
        g.bodies.len(),
        g.gears.len(),
        g.meshes.len(),
        g.shafts.len()
    ));
    h.push_str("<h2>Layout</h2>\n<p>Each gear's reference circle at its axis, to scale; red lines join meshing gears; bodies joined by a shaft share an axis.</p>\n<p><img src=\"layout.svg\" alt=\"layout of the gearbox\" style=\"max-width:100%\"></p>\n");
    h.push_str(&format!(
        "<h2>Interfaces</h2>\n<ul>\n<li><b>Co-Simulation</b>: the FMU integrates and locates every tooth-pair event inside each step.</li>\n<li><b>Model Exchange</b>: {} continuous states (<code>W_ext</code>, <code>W_loss</code>, then a value and a rate per coordinate, one coordinate per body; a speed-driven body's rate is its input, not a state) and {} event indicators ({} per mesh). Use a master with root finding (CVode).</li>\n<li><b>FMI 3.0</b>: <code>{}-fmi3.fmu</code>, the same binary and variables.</li>\n</ul>\n",
        fmu.n_states(),
        fmu.n_event_indicators(),
        fmu.n_event_indicators() / g.meshes.len().max(1),
        esc(&g.name)
    ));
    h.push_str("<p>A gear's parameters (<code>GEAR.z</code>, <code>GEAR.x</code>, ...) set the pair parameters of every mesh of the gear; they may change before initialization only. Start speeds come from the file, and from rigid rolling for the bodies it leaves out.</p>\n");
    h.push_str("<h2>Variables</h2>\n<table><tr><th>name</th><th>value reference</th><th>causality</th><th>unit</th><th>start</th><th>description</th></tr>\n");
    for v in &t.vars {
        let start = match &v.start {
            Some(toml::Value::Float(f)) => f.to_string(),
            Some(toml::Value::String(s)) => format!("\"{s}\""),
            Some(x) => x.to_string(),
            None => String::new(),
        };
        h.push_str(&format!(
            "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            esc(&v.name),
            v.vr,
            v.causality,
            v.unit.as_deref().unwrap_or(""),
            esc(&start),
            esc(&v.description)
        ));
    }
    h.push_str("</table>\n</body></html>\n");
    h
}
