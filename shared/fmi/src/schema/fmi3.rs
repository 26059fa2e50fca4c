//! FMI 3.0 `modelDescription.xml` (FMI 3.0 specification, section 2.4) onto the version-free
//! [`ModelDescription`]: typed variables (`Float64`, `Float32`, `Int8` … `UInt64`, `Boolean`,
//! `String`, `Binary`, `Enumeration`, `Clock`) become [`ScalarVariable`]s of the matching
//! [`VarType`] with their exact [`Fmi3Storage`]; an array becomes one variable per element,
//! named `name[i]` or `name[i,j]` (1-based, as FMPy and Modelica write them) with a value
//! reference of fmucal's own past the FMU's largest; the model structure, which 3.0 writes with
//! value references, is turned into the 1-based variable indices of FMI 2.0; the instantiation
//! token is kept as the GUID. FMUs that need Scheduled Execution or clocks are refused with
//! [`SchemaError::UnsupportedFeature`].

use std::collections::HashMap;

use quick_xml::Reader;
use quick_xml::events::Event;

use super::{
    Attrs, Causality, Fmi3Storage, Fmi3Type, Initial, InterfaceInfo, ModelDescription, ScalarVariable, SchemaError,
    SimpleType, Unit, Unknown, Value, VarType, err_invalid,
};

/// The `fmiVersion` of the root element (read from the first element only).
pub(super) fn root_version(xml: &str) -> Option<String> {
    let mut reader = Reader::from_str(xml);
    loop {
        match reader.read_event() {
            Ok(Event::Start(e) | Event::Empty(e)) => {
                return e.try_get_attribute("fmiVersion").ok().flatten().map(|a| a.value.to_string());
            }
            Ok(Event::Eof) | Err(_) => return None,
            Ok(_) => {}
        }
    }
}

/// The most variables a description may have once its arrays are expanded (one per element).
pub const MAX_VARIABLES: usize = 1_000_000;

/// The most dependency entries kept from `ModelStructure` (past it, unknowns keep none).
const MAX_DEPENDENCIES: usize = 10_000_000;

/// A variable as written, before its array is expanded.
struct RawVariable {
    var: ScalarVariable,
    ty: Fmi3Type,
    /// `Dimension` elements: a fixed size, or the value reference of a structural parameter.
    dimensions: Vec<DimensionSize>,
    /// The start attribute, or the `Start value=…` children of a String/Binary, as written.
    start: Vec<String>,
    /// The value reference of the state this is the derivative of.
    derivative_of: Option<u32>,
    /// Its `<Alias>` elements: name, description, display unit.
    aliases: Vec<(String, Option<String>, Option<String>)>,
}

enum DimensionSize {
    Fixed(usize),
    Parameter(u32),
}

#[derive(Default)]
struct Parser {
    md: Option<ModelDescription>,
    raw: Vec<RawVariable>,
    scheduled_execution: bool,
    /// ModelStructure lists, by value reference: (list, value reference, dependencies).
    structure: Vec<(&'static str, u32, Option<Vec<u32>>)>,
    event_indicators: Vec<u32>,
}

/// Parses an FMI 3.0 description.
///
/// # Errors
/// [`SchemaError::Xml`] for malformed XML, [`SchemaError::Invalid`] for a description that
/// breaks FMI 3.0's rules, [`SchemaError::UnsupportedFeature`] for Scheduled Execution only, or
/// clocks.
pub(super) fn parse(xml: &str) -> Result<ModelDescription, SchemaError> {
    let mut p = Parser::default();
    super::walk(xml, |parent, name, attrs| p.open(parent, name, attrs))?;
    p.finish()
}

fn fmi3_type(elem: &str) -> Option<Fmi3Type> {
    Some(match elem {
        "Float32" => Fmi3Type::Float32,
        "Float64" => Fmi3Type::Float64,
        "Int8" => Fmi3Type::Int8,
        "UInt8" => Fmi3Type::UInt8,
        "Int16" => Fmi3Type::Int16,
        "UInt16" => Fmi3Type::UInt16,
        "Int32" => Fmi3Type::Int32,
        "UInt32" => Fmi3Type::UInt32,
        "Int64" => Fmi3Type::Int64,
        "UInt64" => Fmi3Type::UInt64,
        "Boolean" => Fmi3Type::Boolean,
        "String" => Fmi3Type::String,
        "Binary" => Fmi3Type::Binary,
        "Enumeration" => Fmi3Type::Enumeration,
        "Clock" => Fmi3Type::Clock,
        _ => return None,
    })
}

fn var_type(ty: Fmi3Type) -> VarType {
    match ty {
        Fmi3Type::Float32 | Fmi3Type::Float64 => VarType::Real,
        Fmi3Type::Boolean => VarType::Boolean,
        Fmi3Type::String => VarType::String,
        Fmi3Type::Binary => VarType::Binary,
        Fmi3Type::Enumeration => VarType::Enumeration,
        Fmi3Type::Clock => VarType::Clock,
        _ => VarType::Integer,
    }
}

fn value_references(list: &str, what: &str) -> Result<Vec<u32>, SchemaError> {
    list.split_whitespace()
        .map(|x| x.parse().map_err(|_| err_invalid(format!("{what}: {x:?} is not a value reference"))))
        .collect()
}

fn interface(elem: &str, a: &Attrs) -> Result<InterfaceInfo, SchemaError> {
    Ok(InterfaceInfo {
        model_identifier: a.required(elem, "modelIdentifier")?,
        needs_execution_tool: a.bool(elem, "needsExecutionTool")?,
        can_be_instantiated_only_once_per_process: a.bool(elem, "canBeInstantiatedOnlyOncePerProcess")?,
        can_not_use_memory_management_functions: false,
        can_get_and_set_fmu_state: a.bool(elem, "canGetAndSetFMUState")?,
        can_serialize_fmu_state: a.bool(elem, "canSerializeFMUState")?,
        provides_directional_derivative: a.bool(elem, "providesDirectionalDerivatives")?,
        completed_integrator_step_not_needed: elem == "ModelExchange"
            && !a.bool(elem, "needsCompletedIntegratorStep")?,
        can_handle_variable_communication_step_size: a.bool(elem, "canHandleVariableCommunicationStepSize")?,
        can_interpolate_inputs: a.bool(elem, "canInterpolateInputs")?,
        max_output_derivative_order: a.int(elem, "maxOutputDerivativeOrder")?.unwrap_or(0),
        can_run_asynchronuously: false,
    })
}

impl Parser {
    fn md(&mut self, elem: &str) -> Result<&mut ModelDescription, SchemaError> {
        super::opened(&mut self.md, elem)
    }

    fn open(&mut self, parent: Option<&str>, name: &str, a: &Attrs) -> Result<(), SchemaError> {
        match (parent, name) {
            (None, "fmiModelDescription") => {
                let md = ModelDescription::from_root(name, a, a.required(name, "fmiVersion")?, "instantiationToken")?;
                self.md = Some(md);
            }
            (None, other) => {
                return Err(err_invalid(format!("root element is <{other}>, expected <fmiModelDescription>")));
            }
            (Some("fmiModelDescription"), "ModelExchange" | "CoSimulation") => {
                let info = interface(name, a)?;
                let md = self.md(name)?;
                if name == "ModelExchange" {
                    md.model_exchange = Some(info);
                } else {
                    md.co_simulation = Some(info);
                }
            }
            (Some("fmiModelDescription"), "ScheduledExecution") => self.scheduled_execution = true,
            (Some("UnitDefinitions"), "Unit") => {
                let unit = Unit { name: a.required(name, "name")?, base_unit: None, display_units: vec![] };
                self.md(name)?.unit_definitions.push(unit);
            }
            (Some("Unit"), "BaseUnit") => {
                let base = super::base_unit(name, a)?;
                if let Some(unit) = self.md(name)?.unit_definitions.last_mut() {
                    unit.base_unit = Some(base);
                }
            }
            (Some("Unit"), "DisplayUnit") => {
                let du = super::display_unit(name, a)?;
                if let Some(unit) = self.md(name)?.unit_definitions.last_mut() {
                    unit.display_units.push(du);
                }
            }
            (Some("TypeDefinitions"), type_elem) if type_elem.ends_with("Type") => {
                let Some(ty) = fmi3_type(type_elem.trim_end_matches("Type")) else { return Ok(()) };
                // FMI 3.0 writes the type's attributes on the element itself.
                let mut st = SimpleType::named(name, a)?;
                st.apply(var_type(ty), name, a)?;
                self.md(name)?.type_definitions.push(st);
            }
            (Some("EnumerationType"), "Item") => {
                let item = super::enum_item(name, a)?;
                if let Some(st) = self.md(name)?.type_definitions.last_mut() {
                    st.items.push(item);
                }
            }
            (Some("LogCategories"), "Category") => {
                let cat = a.required(name, "name")?;
                self.md(name)?.log_categories.push(cat);
            }
            (Some("fmiModelDescription"), "DefaultExperiment") => {
                let de = super::default_experiment(name, a)?;
                self.md(name)?.default_experiment = Some(de);
            }
            (Some("ModelVariables"), elem) => {
                let ty = fmi3_type(elem).ok_or_else(|| err_invalid(format!("unknown variable element <{elem}>")))?;
                let raw = variable(ty, a)?;
                self.raw.push(raw);
            }
            (Some(var_elem), "Dimension") if fmi3_type(var_elem).is_some() => {
                let raw = self.raw.last_mut().ok_or_else(|| err_invalid("<Dimension> outside a variable"))?;
                let size = match (a.int::<usize>(name, "start")?, a.int::<u32>(name, "valueReference")?) {
                    (Some(n), _) => DimensionSize::Fixed(n),
                    (None, Some(vr)) => DimensionSize::Parameter(vr),
                    (None, None) => {
                        return Err(err_invalid(format!(
                            "variable {:?}: <Dimension> has neither start nor valueReference",
                            raw.var.name
                        )));
                    }
                };
                raw.dimensions.push(size);
            }
            (Some(var_elem), "Alias") if fmi3_type(var_elem).is_some() => {
                let raw = self.raw.last_mut().ok_or_else(|| err_invalid("<Alias> outside a variable"))?;
                let alias = a.required(name, "name").map_err(super::in_variable(&raw.var.name))?;
                raw.aliases.push((alias, a.string("description"), a.string("displayUnit")));
            }
            (Some("String" | "Binary"), "Start") => {
                let raw = self.raw.last_mut().ok_or_else(|| err_invalid("<Start> outside a variable"))?;
                raw.start.push(a.string("value").unwrap_or_default());
            }
            (Some("ModelStructure"), list @ ("Output" | "ContinuousStateDerivative" | "InitialUnknown")) => {
                let vr = a
                    .int(name, "valueReference")?
                    .ok_or_else(|| err_invalid(format!("<{list}> has no valueReference")))?;
                let deps = a
                    .get("dependencies")
                    .map(|d| value_references(d, &format!("<{list}> dependencies")))
                    .transpose()?;
                let list = match list {
                    "Output" => "Outputs",
                    "ContinuousStateDerivative" => "Derivatives",
                    _ => "InitialUnknowns",
                };
                self.structure.push((list, vr, deps));
            }
            (Some("ModelStructure"), "EventIndicator") => {
                let vr = a
                    .int(name, "valueReference")?
                    .ok_or_else(|| err_invalid("<EventIndicator> has no valueReference"))?;
                self.event_indicators.push(vr);
            }
            _ => {}
        }
        Ok(())
    }

    fn finish(self) -> Result<ModelDescription, SchemaError> {
        let mut md = self.md.ok_or_else(|| err_invalid("no <fmiModelDescription> root element"))?;
        if md.model_exchange.is_none() && md.co_simulation.is_none() {
            return Err(if self.scheduled_execution {
                SchemaError::UnsupportedFeature(format!(
                    "FMU {} offers only Scheduled Execution, which fmucal does not support (it simulates Model Exchange and Co-Simulation FMUs)",
                    md.model_name
                ))
            } else {
                err_invalid("none of <ModelExchange>, <CoSimulation> is present")
            });
        }
        if let Some(clock) = self.raw.iter().find(|r| r.ty == Fmi3Type::Clock) {
            return Err(SchemaError::UnsupportedFeature(format!(
                "FMU {} has clocks (Clock variable {:?}), which fmucal does not support",
                md.model_name, clock.var.name
            )));
        }
        let by_vr: HashMap<u32, usize> = self.raw.iter().enumerate().map(|(i, r)| (r.var.value_reference, i)).collect();
        if by_vr.len() != self.raw.len() {
            let mut seen = std::collections::HashSet::new();
            let dup = self.raw.iter().find(|r| !seen.insert(r.var.value_reference)).expect("a duplicate exists");
            return Err(err_invalid(format!(
                "variable {:?}: valueReference {} is used by another variable",
                dup.var.name, dup.var.value_reference
            )));
        }
        // Array sizes: fixed, or a structural parameter's start value.
        let sizes: Vec<Vec<usize>> = self
            .raw
            .iter()
            .map(|r| {
                r.dimensions
                    .iter()
                    .map(|d| match d {
                        DimensionSize::Fixed(n) => Ok(*n),
                        DimensionSize::Parameter(vr) => by_vr
                            .get(vr)
                            .and_then(|i| self.raw[*i].start.first())
                            .and_then(|s| s.trim().parse::<usize>().ok())
                            .ok_or_else(|| {
                                err_invalid(format!(
                                    "variable {:?}: its dimension refers to valueReference {vr}, which is not a structural parameter with a start value",
                                    r.var.name
                                ))
                            }),
                    })
                    .collect::<Result<Vec<usize>, SchemaError>>()
            })
            .collect::<Result<_, _>>()?;
        // Expand arrays (at most MAX_VARIABLES variables in all, before anything is allocated):
        // each element gets a value reference of fmucal's past the FMU's largest.
        let mut total: usize = 0;
        for (raw, dims) in self.raw.iter().zip(&sizes) {
            let n = dims.iter().try_fold(1usize, |acc, d| acc.checked_mul(*d));
            // Each alias of the variable copies every element.
            let copies = n.and_then(|n| n.max(1).checked_mul(1 + raw.aliases.len()));
            total = copies.and_then(|n| total.checked_add(n)).filter(|t| *t <= MAX_VARIABLES).ok_or_else(|| {
                err_invalid(format!(
                    "variable {:?}: its array takes the description past {MAX_VARIABLES} variables (array elements and their aliases count one each)",
                    raw.var.name
                ))
            })?;
        }
        let mut next_vr = self.raw.iter().map(|r| r.var.value_reference).max().map_or(0, |m| u64::from(m) + 1);
        let mut indices_of: HashMap<u32, Vec<usize>> = HashMap::new();
        // Per expanded variable: the value reference of the state it is the derivative of.
        let mut derivative_of: Vec<Option<u32>> = vec![];
        for (raw, dims) in self.raw.iter().zip(&sizes) {
            let base = raw.var.value_reference;
            let n: usize = dims.iter().product();
            let elements: Vec<(Option<usize>, String, u32)> = if dims.is_empty() {
                vec![(None, raw.var.name.clone(), base)]
            } else {
                (0..n)
                    .map(|k| {
                        let vr = u32::try_from(next_vr).map_err(|_| {
                            err_invalid("too many array elements to give each a value reference".to_owned())
                        })?;
                        next_vr += 1;
                        Ok((Some(k), format!("{}[{}]", raw.var.name, subscript(k, dims)), vr))
                    })
                    .collect::<Result<_, SchemaError>>()?
            };
            let starts = start_texts(raw, n)?;
            for (element, name, vr) in elements {
                let mut var = raw.var.clone();
                var.name = name;
                var.value_reference = vr;
                var.start = starts
                    .as_ref()
                    .map(|texts| typed_start(raw, texts.get(element.unwrap_or(0)).unwrap_or(&texts[0])))
                    .transpose()?
                    .flatten();
                var.fmi3 = Some(Fmi3Storage { ty: raw.ty, value_reference: base, element, dimensions: dims.clone() });
                indices_of.entry(base).or_default().push(md.variables.len() + 1);
                md.variables.push(var);
                derivative_of.push(raw.derivative_of);
            }
        }
        // derivative="vr of the state": the state's index, element by element.
        for (k, state_vr) in derivative_of.into_iter().enumerate() {
            let Some(state_vr) = state_vr else { continue };
            let states = indices_of.get(&state_vr).ok_or_else(|| {
                err_invalid(format!(
                    "variable {:?}: derivative refers to valueReference {state_vr}, which no variable has",
                    md.variables[k].name
                ))
            })?;
            let var = &md.variables[k];
            let position = var.fmi3.as_ref().and_then(|s| s.element).unwrap_or(0);
            let state = *states.get(position).ok_or_else(|| {
                err_invalid(format!(
                    "variable {:?}: derivative of valueReference {state_vr}, which has only {} element(s)",
                    var.name,
                    states.len()
                ))
            })?;
            md.variables[k].derivative = Some(state);
        }
        let to_indices = |vr: u32, what: &str| -> Result<Vec<usize>, SchemaError> {
            indices_of
                .get(&vr)
                .cloned()
                .ok_or_else(|| err_invalid(format!("ModelStructure/{what}: no variable has valueReference {vr}")))
        };
        let mut kept_dependencies: usize = 0;
        for (list, vr, deps) in &self.structure {
            let mut dependencies = deps
                .as_ref()
                .map(|d| d.iter().map(|v| to_indices(*v, list)).collect::<Result<Vec<_>, _>>().map(|v| v.concat()))
                .transpose()?;
            // Dependencies only refine what an unknown depends on; past the cap, an unknown is
            // taken to depend on everything (no list), as FMI allows.
            let copies = indices_of.get(vr).map_or(0, Vec::len);
            let cost = dependencies.as_ref().map_or(0, |d| d.len().saturating_mul(copies));
            if kept_dependencies.saturating_add(cost) > MAX_DEPENDENCIES {
                dependencies = None;
            } else {
                kept_dependencies += cost;
            }
            for index in to_indices(*vr, list)? {
                let unknown = Unknown { index, dependencies: dependencies.clone() };
                match *list {
                    "Outputs" => md.model_structure.outputs.push(unknown),
                    "Derivatives" => md.model_structure.derivatives.push(unknown),
                    _ => md.model_structure.initial_unknowns.push(unknown),
                }
            }
        }
        // Each <Alias> is a variable of its own that shares its base's value (element by
        // element for an array), listed after every variable so the model structure's indices
        // stay as they are, and never itself an output or a state.
        // Element names and array names are taken (an alias called like an array would hide it).
        let mut names: std::collections::HashSet<String> =
            md.variables.iter().map(|v| v.name.clone()).chain(self.raw.iter().map(|r| r.var.name.clone())).collect();
        for raw in self.raw.iter().filter(|r| !r.aliases.is_empty()) {
            let elements = indices_of.get(&raw.var.value_reference).cloned().unwrap_or_default();
            for (alias, description, display_unit) in &raw.aliases {
                for &index in &elements {
                    let base = &md.variables[index - 1];
                    let mut var = base.clone();
                    var.name = format!("{alias}{}", &base.name[raw.var.name.len()..]);
                    var.alias_of = Some(base.name.clone());
                    var.description = description.clone().or_else(|| base.description.clone());
                    var.display_unit = display_unit.clone().or_else(|| base.display_unit.clone());
                    if !names.insert(var.name.clone()) {
                        return Err(err_invalid(format!(
                            "alias {:?} of variable {:?}: another variable has that name",
                            var.name, raw.var.name
                        )));
                    }
                    md.variables.push(var);
                }
            }
        }
        for vr in &self.event_indicators {
            md.number_of_event_indicators += indices_of.get(vr).map(Vec::len).ok_or_else(|| {
                err_invalid(format!("ModelStructure/EventIndicator: no variable has valueReference {vr}"))
            })?;
        }
        super::finish(&mut md)?;
        Ok(md)
    }
}

/// `2` or `1,3`: the 1-based subscripts of the flattened (row-major) position `k`.
fn subscript(mut k: usize, dims: &[usize]) -> String {
    let mut subs = vec![0; dims.len()];
    for (d, n) in dims.iter().enumerate().rev() {
        subs[d] = k % n + 1;
        k /= n;
    }
    subs.iter().map(usize::to_string).collect::<Vec<_>>().join(",")
}

/// The start values as written, one per element (or one for all), or `None` without any.
fn start_texts(raw: &RawVariable, n: usize) -> Result<Option<Vec<&str>>, SchemaError> {
    let values: Vec<&str> = match raw.ty {
        Fmi3Type::String | Fmi3Type::Binary => raw.start.iter().map(String::as_str).collect(),
        _ => raw.start.iter().flat_map(|s| s.split_whitespace()).collect(),
    };
    if values.is_empty() {
        return Ok(None);
    }
    // One start value for a whole array applies to every element.
    if values.len() != 1 && values.len() != n.max(1) {
        return Err(err_invalid(format!(
            "variable {:?}: {} start values for {n} elements",
            raw.var.name,
            values.len()
        )));
    }
    Ok(Some(values))
}

/// One start value, typed (a Binary's in hex).
fn typed_start(raw: &RawVariable, text: &str) -> Result<Option<Value>, SchemaError> {
    // A UInt64 start past i64::MAX is kept as the nearest Real.
    if raw.ty == Fmi3Type::UInt64 && text.trim().parse::<i64>().is_err() {
        if let Ok(big) = text.trim().parse::<u64>() {
            return Ok(Some(Value::Real(big as f64)));
        }
    }
    super::parse_start(var_type(raw.ty), text, &raw.var.name)
}

fn variable(ty: Fmi3Type, a: &Attrs) -> Result<RawVariable, SchemaError> {
    let elem = format!("{ty:?}");
    let name = a.required(&elem, "name")?;
    let value_reference = super::value_reference(a, &name)?;
    let causality = match a.get("causality").unwrap_or("local") {
        // A structural parameter may size arrays, and fmucal keeps the sizes of the description:
        // it is read, never set.
        "structuralParameter" => Causality::CalculatedParameter,
        other => super::causality(other, &name)?,
    };
    let default_variability =
        if matches!(ty, Fmi3Type::Float32 | Fmi3Type::Float64) { "continuous" } else { "discrete" };
    let variability = super::variability(a.get("variability").unwrap_or(default_variability), &name)?;
    let initial = super::initial(a, &name)?;
    let ectx = super::in_variable(&name);
    // A structural parameter is never set (see its causality above).
    let initial = if a.get("causality") == Some("structuralParameter") { Some(Initial::Calculated) } else { initial };
    let mut var =
        ScalarVariable::new(name.clone(), value_reference, a.string("description"), causality, variability, initial);
    var.var_type = var_type(ty);
    var.declared_type = a.string("declaredType");
    var.min = a.f64(&elem, "min").map_err(&ectx)?;
    var.max = a.f64(&elem, "max").map_err(&ectx)?;
    var.nominal = a.f64(&elem, "nominal").map_err(&ectx)?;
    var.unit = a.string("unit");
    var.display_unit = a.string("displayUnit");
    var.reinit = a.bool(&elem, "reinit").map_err(&ectx)?;
    Ok(RawVariable {
        var,
        ty,
        dimensions: vec![],
        start: a.string("start").into_iter().collect(),
        derivative_of: a.int(&elem, "derivative").map_err(&ectx)?,
        aliases: vec![],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="M" instantiationToken="{t}">
  <ModelExchange modelIdentifier="M"/>
  <CoSimulation modelIdentifier="M" canHandleVariableCommunicationStepSize="true"/>
  <TypeDefinitions>
    <Float64Type name="Length" unit="m" min="-10"/>
    <EnumerationType name="Mode"><Item name="off" value="1"/><Item name="on" value="2"/></EnumerationType>
  </TypeDefinitions>
  <ModelVariables>
    <Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>
    <Float64 name="x" valueReference="1" causality="output" initial="exact" start="2" declaredType="Length"/>
    <Float64 name="der(x)" valueReference="2" derivative="1"/>
    <Float64 name="k" valueReference="3" causality="parameter" variability="tunable" start="1 2 3">
      <Dimension start="3"/>
    </Float64>
    <Float32 name="y" valueReference="4" causality="output"/>
    <Int8 name="n" valueReference="5" causality="parameter" variability="fixed" start="-3"/>
    <Enumeration name="mode" valueReference="6" declaredType="Mode" causality="parameter" variability="fixed" start="2"/>
    <Float64 name="z" valueReference="7"/>
    <UInt64 name="rows" valueReference="8" causality="structuralParameter" variability="fixed" start="2"/>
    <Float64 name="m" valueReference="9" causality="parameter" variability="fixed" start="11 12 13 21 22 23">
      <Dimension valueReference="8"/><Dimension start="3"/>
    </Float64>
    <String name="label" valueReference="10" causality="parameter" variability="fixed"><Start value="hi"/></String>
  </ModelVariables>
  <ModelStructure>
    <Output valueReference="1"/>
    <Output valueReference="4" dependencies="1 3"/>
    <ContinuousStateDerivative valueReference="2"/>
    <InitialUnknown valueReference="2"/>
    <EventIndicator valueReference="7"/>
  </ModelStructure>
</fmiModelDescription>"#;

    #[test]
    fn a_3_0_description_maps_onto_the_version_free_structs() {
        let md = ModelDescription::parse(MINIMAL).unwrap();
        assert_eq!(md.fmi_version, "3.0");
        assert_eq!(md.guid, "{t}");
        let states = md.states();
        assert_eq!(states.len(), 1);
        assert_eq!((states[0].0.name.as_str(), states[0].1.name.as_str()), ("x", "der(x)"));
        assert_eq!(md.number_of_event_indicators, 1);
        let outputs: Vec<&str> = md.outputs().iter().map(|v| v.name.as_str()).collect();
        assert_eq!(outputs, ["x", "y"]);
        let x = md.variable("x").unwrap();
        assert_eq!((x.unit.as_deref(), x.min), (Some("m"), Some(-10.0)));
        let y = md.variable("y").unwrap();
        assert_eq!((y.var_type, y.fmi3.as_ref().unwrap().ty), (VarType::Real, Fmi3Type::Float32));
        let n = md.variable("n").unwrap();
        assert_eq!((n.var_type, n.start.clone()), (VarType::Integer, Some(Value::Integer(-3))));
        assert_eq!(md.variable("mode").unwrap().var_type, VarType::Enumeration);
        assert_eq!(md.variable("label").unwrap().start, Some(Value::String("hi".into())));
        // The dependencies of y name k's three elements.
        let y_deps = md.model_structure.outputs[1].dependencies.clone().unwrap();
        assert_eq!(y_deps.len(), 4);
    }

    #[test]
    fn arrays_become_one_variable_per_element_with_values_references_of_their_own() {
        let md = ModelDescription::parse(MINIMAL).unwrap();
        for (i, want) in [1.0, 2.0, 3.0].iter().enumerate() {
            let k = md.variable(&format!("k[{}]", i + 1)).unwrap();
            assert_eq!(k.start, Some(Value::Real(*want)));
            let s = k.fmi3.as_ref().unwrap();
            assert_eq!((s.value_reference, s.element, s.dimensions.clone()), (3, Some(i), vec![3]));
            assert!(k.value_reference > 10, "element {i} kept the array's value reference");
        }
        assert!(md.variable("k").is_none(), "the array itself is not a variable");
        // Two rows (a structural parameter) of three: row-major, 1-based subscripts.
        let m = md.variable("m[2,1]").unwrap();
        assert_eq!(m.start, Some(Value::Real(21.0)));
        assert_eq!(m.fmi3.as_ref().unwrap().element, Some(3));
        assert!(md.variable("m[2,3]").is_some() && md.variable("m[3,1]").is_none());
        let mut vrs: Vec<u32> = md.variables.iter().map(|v| v.value_reference).collect();
        let n = vrs.len();
        vrs.sort_unstable();
        vrs.dedup();
        assert_eq!(vrs.len(), n, "value references are not unique");
    }

    #[test]
    fn alias_elements_are_variables_that_share_their_base_value() {
        let xml = MINIMAL
            .replace(
                r#"initial="exact" start="2" declaredType="Length"/>"#,
                r#"initial="exact" start="2" declaredType="Length"><Alias name="x_ft" description="x in feet" displayUnit="ft"/></Float64>"#,
            )
            .replacen(r#"<Dimension start="3"/>"#, r#"<Dimension start="3"/><Alias name="gains"/>"#, 1);
        let md = ModelDescription::parse(&xml).unwrap();
        let (x, alias) = (md.variable("x").unwrap(), md.variable("x_ft").unwrap());
        assert_eq!(
            (alias.value_reference, alias.causality, alias.start.clone()),
            (x.value_reference, x.causality, x.start.clone())
        );
        assert_eq!((alias.alias_of.as_deref(), alias.display_unit.as_deref()), (Some("x"), Some("ft")));
        assert_eq!(alias.description.as_deref(), Some("x in feet"));
        assert_eq!(md.base_of(alias).name, "x");
        // An alias of an array aliases each element; neither becomes an output or a state.
        for i in 1..=3 {
            let (k, g) = (md.variable(&format!("k[{i}]")).unwrap(), md.variable(&format!("gains[{i}]")).unwrap());
            assert_eq!((g.value_reference, g.fmi3.clone()), (k.value_reference, k.fmi3.clone()));
            assert_eq!(g.alias_of.as_deref(), Some(k.name.as_str()));
        }
        let names = |vars: Vec<&ScalarVariable>| vars.iter().map(|v| v.name.clone()).collect::<Vec<_>>();
        assert_eq!(names(md.outputs()), ["x", "y"]);
        assert_eq!(md.states().len(), 1);
        assert_eq!(names(md.array_elements("gains").unwrap()), ["gains[1]", "gains[2]", "gains[3]"]);
        assert_eq!(names(md.array_elements("k").unwrap()), ["k[1]", "k[2]", "k[3]"]);
        assert!(md.array_elements("x").is_none());
        let clash = xml.replace(r#"name="x_ft""#, r#"name="z""#);
        let err = ModelDescription::parse(&clash).unwrap_err().to_string();
        assert!(err.contains(r#"alias "z" of variable "x": another variable has that name"#), "{err}");
    }

    #[test]
    fn binary_start_elements_are_read_as_hex_and_do_not_refuse_an_input() {
        let xml = MINIMAL.replace(
            "</ModelVariables>",
            r#"<Binary name="Binary_input" valueReference="30" causality="input"><Start value="666f6f"/></Binary>
<Binary name="Binary_parameter" valueReference="31" causality="parameter" variability="fixed"><Start value="0x0A0b"/></Binary>
</ModelVariables>"#,
        );
        let md = ModelDescription::parse(&xml).unwrap();
        assert_eq!(md.variable("Binary_input").unwrap().start, Some(Value::Binary(b"foo".to_vec())));
        let p = md.variable("Binary_parameter").unwrap();
        assert_eq!(p.start, Some(Value::Binary(vec![10, 11])));
        assert_eq!(p.start.as_ref().unwrap().to_string(), "0x0a0b");
        // A String or Binary input without a start value is no reason to refuse the FMU.
        let no_start = xml.replace(r#"<Start value="666f6f"/>"#, "");
        assert_eq!(ModelDescription::parse(&no_start).unwrap().variable("Binary_input").unwrap().start, None);
        let bad = xml.replace("666f6f", "66z");
        let err = ModelDescription::parse(&bad).unwrap_err().to_string();
        assert!(err.contains("Binary_input") && err.contains("hex"), "{err}");
    }

    #[test]
    fn clocks_and_scheduled_execution_alone_are_refused_naming_the_feature() {
        let clocked = MINIMAL.replace(
            "</ModelVariables>",
            r#"<Clock name="tick" valueReference="20" causality="input" variability="discrete" intervalVariability="constant"/></ModelVariables>"#,
        );
        let err = ModelDescription::parse(&clocked).unwrap_err();
        assert!(matches!(err, SchemaError::UnsupportedFeature(_)), "{err:?}");
        assert!(err.to_string().contains("clocks (Clock variable \"tick\")"), "{err}");
        let scheduled = MINIMAL
            .replace(r#"<ModelExchange modelIdentifier="M"/>"#, r#"<ScheduledExecution modelIdentifier="M"/>"#)
            .replace(r#"<CoSimulation modelIdentifier="M" canHandleVariableCommunicationStepSize="true"/>"#, "");
        let err = ModelDescription::parse(&scheduled).unwrap_err().to_string();
        assert!(err.contains("offers only Scheduled Execution"), "{err}");
    }

    #[test]
    fn huge_arrays_are_refused_before_they_are_allocated() {
        for dims in
            [r#"<Dimension start="1000000000"/>"#, r#"<Dimension start="4294967296"/><Dimension start="4294967296"/>"#]
        {
            let xml = MINIMAL.replace(r#"<Dimension start="3"/>"#, dims);
            let err = ModelDescription::parse(&xml).unwrap_err().to_string();
            assert!(err.contains("variable \"k\": its array takes the description past 1000000 variables"), "{err}");
        }
        let md = ModelDescription::parse(MINIMAL).unwrap();
        assert!(!md.variable("rows").unwrap().settable_before_init(), "a structural parameter was settable");
    }

    #[test]
    fn broken_references_are_invalid_with_the_variable_named() {
        let cases = [
            (r#"derivative="1""#, r#"derivative="99""#, "derivative refers to valueReference 99"),
            (
                r#"<Output valueReference="4" dependencies="1 3"/>"#,
                r#"<Output valueReference="42"/>"#,
                "no variable has valueReference 42",
            ),
            (r#"valueReference="4""#, r#"valueReference="3""#, "valueReference 3 is used by another variable"),
            (r#"start="1 2 3""#, r#"start="1 2""#, "2 start values for 3 elements"),
            (r#"<Dimension valueReference="8"/>"#, r#"<Dimension valueReference="4"/>"#, "not a structural parameter"),
        ];
        for (from, to, want) in cases {
            let xml = MINIMAL.replacen(from, to, 1);
            let err = ModelDescription::parse(&xml).unwrap_err().to_string();
            assert!(err.contains(want), "{from} -> {to}: {err}");
        }
    }
}
