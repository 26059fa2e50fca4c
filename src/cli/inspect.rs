//! `fmucal inspect`: version, interfaces, generation tool, default experiment, the platforms
//! the archive has binaries for, a table of parameters, inputs, outputs and states with
//! start values and units, the aliases with the variable each shares its value with, and the
//! model's physical structure ([`Structure`]: each state's quantity, role, position/velocity
//! pair and derivative aliases, each injection port with the states it pairs with). It reads
//! the description only and never loads the binary, so it works on FMUs built for other
//! platforms and runs no model code. `--json` prints the description with the structure under
//! a top-level `structure` key.

use anyhow::{Context, Result};
use fmucal_shared::diagnose::structure::Structure;
use fmucal_shared::fmu::schema::{Causality, ModelDescription, ScalarVariable};
use fmucal_shared::fmu::{Described, LoadOptions, describe, platform_folder};

#[derive(clap::Args)]
pub struct Args {
    /// The FMU: a path, or the name of a built-in example.
    model: String,
    /// Print the full model description as JSON, with its structure under `structure`.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let path = super::model_arg::resolve(&args.model)?;
    let fmu = describe(&path, &LoadOptions::default()).with_context(|| format!("cannot read {}", path.display()))?;
    if args.json {
        let mut json = serde_json::to_value(fmu.description.as_ref())?;
        if let Some(object) = json.as_object_mut() {
            object.insert("structure".into(), serde_json::to_value(Structure::read(&fmu.description, &[]))?);
        }
        println!("{}", serde_json::to_string_pretty(&json)?);
        return Ok(());
    }
    print!("{}", render(&fmu));
    Ok(())
}

fn render(fmu: &Described) -> String {
    let md: &ModelDescription = &fmu.description;
    let mut s = String::new();
    let mut line = |k: &str, v: String| s.push_str(&format!("{k:<18} {v}\n"));
    line("Model", md.model_name.clone());
    line("FMI version", md.fmi_version.clone());
    line("GUID", md.guid.clone());
    line("Generation tool", md.generation_tool.clone().unwrap_or_else(|| "-".into()));
    let mut interfaces = vec![];
    if let Some(me) = &md.model_exchange {
        interfaces.push(format!("Model Exchange ({})", me.model_identifier));
    }
    if let Some(cs) = &md.co_simulation {
        interfaces.push(format!("Co-Simulation ({})", cs.model_identifier));
    }
    line("Interfaces", interfaces.join(", "));
    line("Event indicators", md.number_of_event_indicators.to_string());
    let platforms = if fmu.platforms.is_empty() { "none".to_owned() } else { fmu.platforms.join(", ") };
    if fmu.missing_binaries.is_empty() {
        line("Binaries", platforms);
    } else {
        line(
            "Binaries",
            format!(
                "{platforms} (no {} binary {}: it cannot be simulated on this machine)",
                platform_folder(md),
                fmu.missing_binaries.join(", ")
            ),
        );
    }
    if let Some(de) = &md.default_experiment {
        let f = |v: Option<f64>| v.map(|x| x.to_string()).unwrap_or_else(|| "-".into());
        line(
            "Default experiment",
            format!(
                "start {}, stop {}, tolerance {}, step {}",
                f(de.start_time),
                f(de.stop_time),
                f(de.tolerance),
                f(de.step_size)
            ),
        );
    }
    let states: Vec<&ScalarVariable> = md.states().into_iter().map(|(s, _)| s).collect();
    let groups: [(&str, Vec<&ScalarVariable>); 4] = [
        ("Parameters", md.variables.iter().filter(|v| v.causality == Causality::Parameter).collect()),
        ("Inputs", md.variables.iter().filter(|v| v.causality == Causality::Input).collect()),
        ("Outputs", md.variables.iter().filter(|v| v.causality == Causality::Output).collect()),
        ("States", states),
    ];
    for (title, vars) in groups {
        s.push_str(&format!("\n{title} ({})\n", vars.len()));
        if vars.is_empty() {
            continue;
        }
        s.push_str(&format!("  {:<28} {:<12} {:<12} {:<10} {}\n", "name", "type", "start", "unit", "description"));
        for v in vars {
            s.push_str(&format!(
                "  {:<28} {:<12} {:<12} {:<10} {}\n",
                v.name,
                type_cell(v),
                v.start.as_ref().map(|x| x.to_string()).unwrap_or_else(|| "-".into()),
                v.unit.clone().unwrap_or_else(|| "-".into()),
                v.description.clone().unwrap_or_default()
            ));
        }
    }
    let aliases: Vec<&ScalarVariable> = md.variables.iter().filter(|v| v.alias_of.is_some()).collect();
    if !aliases.is_empty() {
        s.push_str(&format!("\nAliases ({})\n", aliases.len()));
        s.push_str(&format!("  {:<28} {:<28} {:<12} {}\n", "name", "alias of", "display unit", "description"));
        for v in aliases {
            let base = v.alias_of.as_deref().unwrap_or_default();
            s.push_str(&format!(
                "  {:<28} {:<28} {:<12} {}\n",
                v.name,
                if v.negated { format!("-{base} (negated)") } else { base.to_owned() },
                v.display_unit.clone().unwrap_or_else(|| "-".into()),
                v.description.clone().unwrap_or_default()
            ));
        }
    }
    s.push_str(&Structure::read(md, &[]).render());
    s
}

/// The type column: FMI 2.0's base type, or FMI 3.0's exact type with the dimensions of the
/// array an element belongs to (`Float64[2×3]`).
fn type_cell(v: &ScalarVariable) -> String {
    match &v.fmi3 {
        Some(s) if !s.dimensions.is_empty() => {
            let dims: Vec<String> = s.dimensions.iter().map(usize::to_string).collect();
            format!("{:?}[{}]", s.ty, dims.join("×"))
        }
        Some(s) => format!("{:?}", s.ty),
        None => format!("{:?}", v.var_type),
    }
}
