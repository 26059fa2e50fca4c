//! `fmucal inspect`: version, interfaces, generation tool, default experiment, the platforms
//! the archive has binaries for, a table of parameters, inputs, outputs and states (and, with
//! `--all`, local variables) with start values and units, the aliases with the variable each
//! shares its value with, and the
//! model's physical structure ([`Structure`]: each state's quantity, role, position/velocity
//! pair and derivative aliases, each injection port with the states it pairs with). It reads
//! the description only and never loads the binary, so it works on FMUs built for other
//! platforms and runs no model code. `--json` prints the description with the structure under
//! a top-level `structure` key.
//!
//! The tables keep their columns whatever the model holds: a cell wider than its column is cut
//! to it with an ellipsis ([`WIDTHS`]), and line breaks in a cell print as spaces.

use anyhow::{Context, Result};
use fmucal_shared::fmu::schema::{Causality, ModelDescription, ScalarVariable};
use fmucal_shared::fmu::{Described, LoadOptions, describe, platform_folder};
use fmucal_shared::structure::Structure;

#[derive(clap::Args)]
pub struct Args {
    /// The FMU: a path, or the name of a built-in example.
    model: String,
    /// Print the full model description as JSON, with its structure under `structure`.
    #[arg(long)]
    json: bool,
    /// Also list the local variables (causality local: the model's internal variables, which a
    /// job can use as outputs too).
    #[arg(long)]
    all: bool,
}

/// The widest a table column gets, in characters: a longer name, type, start value, unit or
/// description is cut to this with "…" at its end (`--json` prints every value whole). The name
/// column is only as wide as the longest name listed.
const WIDTHS: Widths = Widths { name: 40, kind: 12, start: 16, unit: 10, description: 80 };

struct Widths {
    name: usize,
    kind: usize,
    start: usize,
    unit: usize,
    description: usize,
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
    print!("{}", render(&fmu, args.all));
    Ok(())
}

/// `text` on one line, cut to `width` characters with a final "…" if it is longer.
fn cut(text: &str, width: usize) -> String {
    let one_line: String = text.chars().map(|c| if c.is_control() { ' ' } else { c }).collect();
    if one_line.chars().count() <= width {
        return one_line;
    }
    let mut short: String = one_line.chars().take(width.saturating_sub(1)).collect();
    short.push('…');
    short
}

fn render(fmu: &Described, all: bool) -> String {
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
    let locals: Vec<&ScalarVariable> = md.variables.iter().filter(|v| v.causality == Causality::Local).collect();
    let n_locals = locals.len();
    let mut groups: Vec<(&str, Vec<&ScalarVariable>)> = vec![
        ("Parameters", md.variables.iter().filter(|v| v.causality == Causality::Parameter).collect()),
        ("Inputs", md.variables.iter().filter(|v| v.causality == Causality::Input).collect()),
        ("Outputs", md.variables.iter().filter(|v| v.causality == Causality::Output).collect()),
        ("States", states),
    ];
    if all {
        groups.push(("Locals", locals));
    }
    let aliases: Vec<&ScalarVariable> = md.variables.iter().filter(|v| v.alias_of.is_some()).collect();
    let listed = groups.iter().flat_map(|(_, vars)| vars).chain(&aliases);
    let name_w = listed.map(|v| v.name.chars().count()).max().unwrap_or(0).clamp(8, WIDTHS.name);
    let w = WIDTHS;
    for (title, vars) in groups {
        s.push_str(&format!("\n{title} ({})\n", vars.len()));
        if vars.is_empty() {
            continue;
        }
        s.push_str(&format!(
            "  {:<name_w$} {:<kind$} {:<start$} {:<unit$} {}\n",
            "name",
            "type",
            "start",
            "unit",
            "description",
            kind = w.kind,
            start = w.start,
            unit = w.unit
        ));
        for v in vars {
            let start = v.start.as_ref().map(|x| x.to_string()).unwrap_or_else(|| "-".into());
            let unit = md.unit_of(v).unwrap_or("-");
            let line = format!(
                "  {:<name_w$} {:<kind$} {:<start$} {:<unit$} {}",
                cut(&v.name, name_w),
                cut(&type_cell(v), w.kind),
                cut(&start, w.start),
                cut(unit, w.unit),
                cut(v.description.as_deref().unwrap_or_default(), w.description),
                kind = w.kind,
                start = w.start,
                unit = w.unit
            );
            s.push_str(line.trim_end());
            s.push('\n');
        }
    }
    if !all && n_locals > 0 {
        let (count, pronoun) = if n_locals == 1 {
            ("1 local variable".to_owned(), "it")
        } else {
            (format!("{n_locals} local variables"), "them")
        };
        s.push_str(&format!("\n{count} not listed (valid as outputs too): --all lists {pronoun}\n"));
    }
    if !aliases.is_empty() {
        s.push_str(&format!("\nAliases ({})\n", aliases.len()));
        s.push_str(&format!(
            "  {:<name_w$} {:<name_w$} {:<12} {}\n",
            "name", "alias of", "display unit", "description"
        ));
        for v in aliases {
            let base = v.alias_of.as_deref().unwrap_or_default();
            let base = if v.negated { format!("-{base} (negated)") } else { base.to_owned() };
            let line = format!(
                "  {:<name_w$} {:<name_w$} {:<12} {}",
                cut(&v.name, name_w),
                cut(&base, name_w),
                cut(v.display_unit.as_deref().unwrap_or("-"), 12),
                cut(v.description.as_deref().unwrap_or_default(), w.description)
            );
            s.push_str(line.trim_end());
            s.push('\n');
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
