//! Writes a [`ModelDescription`] as an FMI 2.0 `modelDescription.xml`, whatever version it was
//! read from: the counterpart of the readers, used by `fmucal export`. Everything FMI 2.0 can
//! say is written (units, type definitions, variables with their attributes, the model
//! structure with dependencies); what it cannot say (FMI 3.0 Binary and Clock variables, 64-bit
//! integers, FMI 1.0 negated aliases) is refused naming the variable, never dropped in silence.
//! [`ModelDescription::without_variables`] removes variables first, renumbering every index.

use std::fmt::Write;

use quick_xml::escape::escape;

use super::{
    Causality, Fmi3Type, Initial, InterfaceInfo, ModelDescription, ScalarVariable, SchemaError, Unknown, Value,
    VarType, Variability,
};

/// An `xs:double` as text: the shortest form that reads back to the same value.
fn double(v: f64) -> String {
    if v.is_nan() {
        "NaN".into()
    } else if v.is_infinite() {
        if v > 0.0 { "INF".into() } else { "-INF".into() }
    } else {
        format!("{v:?}")
    }
}

fn attr(out: &mut String, name: &str, value: &str) {
    let _ = write!(out, " {name}=\"{}\"", escape(value));
}

fn opt_attr(out: &mut String, name: &str, value: Option<&str>) {
    if let Some(v) = value {
        attr(out, name, v);
    }
}

fn flag(out: &mut String, name: &str, on: bool) {
    if on {
        attr(out, name, "true");
    }
}

fn causality(c: Causality) -> &'static str {
    match c {
        Causality::Parameter => "parameter",
        Causality::CalculatedParameter => "calculatedParameter",
        Causality::Input => "input",
        Causality::Output => "output",
        Causality::Local => "local",
        Causality::Independent => "independent",
    }
}

fn variability(v: Variability) -> &'static str {
    match v {
        Variability::Constant => "constant",
        Variability::Fixed => "fixed",
        Variability::Tunable => "tunable",
        Variability::Discrete => "discrete",
        Variability::Continuous => "continuous",
    }
}

fn initial(i: Initial) -> &'static str {
    match i {
        Initial::Exact => "exact",
        Initial::Approx => "approx",
        Initial::Calculated => "calculated",
    }
}

fn type_element(t: VarType) -> Option<&'static str> {
    match t {
        VarType::Real => Some("Real"),
        VarType::Integer => Some("Integer"),
        VarType::Boolean => Some("Boolean"),
        VarType::String => Some("String"),
        VarType::Enumeration => Some("Enumeration"),
        VarType::Binary | VarType::Clock => None,
    }
}

fn unwritable(v: &ScalarVariable, why: &str) -> SchemaError {
    SchemaError::UnsupportedFeature(format!(
        "variable {} cannot be written in FMI 2.0: {why}",
        crate::quote::quote_user_text(&v.name)
    ))
}

/// The `<Unknown>` elements of one list.
fn unknowns(out: &mut String, tag: &str, list: &[Unknown]) {
    if list.is_empty() {
        return;
    }
    let _ = writeln!(out, "    <{tag}>");
    for u in list {
        let _ = write!(out, "      <Unknown index=\"{}\"", u.index);
        if let Some(d) = &u.dependencies {
            let deps: Vec<String> = d.iter().map(usize::to_string).collect();
            attr(out, "dependencies", &deps.join(" "));
        }
        out.push_str("/>\n");
    }
    let _ = writeln!(out, "    </{tag}>");
}

fn interface(out: &mut String, tag: &str, i: &InterfaceInfo, cs: bool) {
    let _ = write!(out, "  <{tag}");
    attr(out, "modelIdentifier", &i.model_identifier);
    flag(out, "needsExecutionTool", i.needs_execution_tool);
    flag(out, "canBeInstantiatedOnlyOncePerProcess", i.can_be_instantiated_only_once_per_process);
    flag(out, "canNotUseMemoryManagementFunctions", i.can_not_use_memory_management_functions);
    flag(out, "canGetAndSetFMUstate", i.can_get_and_set_fmu_state);
    flag(out, "canSerializeFMUstate", i.can_serialize_fmu_state);
    flag(out, "providesDirectionalDerivative", i.provides_directional_derivative);
    if cs {
        flag(out, "canHandleVariableCommunicationStepSize", i.can_handle_variable_communication_step_size);
        flag(out, "canInterpolateInputs", i.can_interpolate_inputs);
        if i.max_output_derivative_order > 0 {
            attr(out, "maxOutputDerivativeOrder", &i.max_output_derivative_order.to_string());
        }
        flag(out, "canRunAsynchronuously", i.can_run_asynchronuously);
    } else {
        flag(out, "completedIntegratorStepNotNeeded", i.completed_integrator_step_not_needed);
    }
    out.push_str("/>\n");
}

/// The `initial` attribute written for `v` and the start value that goes with it: a start
/// goes with initial exact or approx (an input's needs none); a start on a variable whose
/// default initial is calculated (FMI 1.0 writes such starts) becomes approx.
fn written_initial(v: &ScalarVariable) -> (Option<Initial>, Option<&Value>) {
    let calculated = v.effective_initial() == Some(Initial::Calculated);
    let start = v.start.as_ref().filter(|_| !(calculated && v.initial.is_some()));
    let init = match (v.initial, start) {
        (Some(i), _) => Some(i),
        (None, Some(_)) if calculated => Some(Initial::Approx),
        _ => None,
    };
    let init = init.filter(|_| !matches!(v.causality, Causality::Input | Causality::Independent));
    (init, start)
}

/// `initial` as an importer reads the written variable: the attribute, else FMI 2.0's default.
fn read_initial(v: &ScalarVariable) -> Option<Initial> {
    written_initial(v).0.or_else(|| ScalarVariable { initial: None, ..v.clone() }.effective_initial())
}

/// The unknowns FMI 2.0 (section 2.2.8) requires in `InitialUnknowns`, as 1-based indices in
/// ascending order: outputs and states and derivatives with initial approx or calculated, and
/// calculated parameters.
fn required_initial_unknowns(md: &ModelDescription) -> Vec<usize> {
    let open = |v: &ScalarVariable| matches!(read_initial(v), Some(Initial::Approx | Initial::Calculated));
    let mut set: Vec<usize> = md
        .variables
        .iter()
        .enumerate()
        .filter(|(_, v)| (v.causality == Causality::Output && open(v)) || v.causality == Causality::CalculatedParameter)
        .map(|(i, _)| i + 1)
        .collect();
    for u in &md.model_structure.derivatives {
        let der = u.index;
        let state = md.variables.get(der - 1).and_then(|d| d.derivative);
        for i in [Some(der), state].into_iter().flatten() {
            if md.variables.get(i - 1).is_some_and(open) {
                set.push(i);
            }
        }
    }
    set.sort_unstable();
    set.dedup();
    set
}

fn variable(out: &mut String, v: &ScalarVariable) -> Result<(), SchemaError> {
    if v.negated {
        return Err(unwritable(v, "it is a negated alias, which FMI 2.0 has no way to say"));
    }
    let Some(element) = type_element(v.var_type) else {
        return Err(unwritable(v, &format!("FMI 2.0 has no {:?} type", v.var_type)));
    };
    if let Some(s) = &v.fmi3
        && matches!(s.ty, Fmi3Type::UInt32 | Fmi3Type::Int64 | Fmi3Type::UInt64)
    {
        return Err(unwritable(v, &format!("an FMI 3.0 {:?} does not fit FMI 2.0's 32-bit Integer", s.ty)));
    }
    let _ = write!(out, "    <ScalarVariable");
    attr(out, "name", &v.name);
    attr(out, "valueReference", &v.value_reference.to_string());
    opt_attr(out, "description", v.description.as_deref());
    attr(out, "causality", causality(v.causality));
    attr(out, "variability", variability(v.variability));
    let (init, start) = written_initial(v);
    if let Some(i) = init {
        attr(out, "initial", initial(i));
    }
    out.push_str(">\n      <");
    out.push_str(element);
    opt_attr(out, "declaredType", v.declared_type.as_deref());
    let number = |x: f64| if matches!(v.var_type, VarType::Real) { double(x) } else { format!("{}", x as i64) };
    if matches!(v.var_type, VarType::Real) {
        opt_attr(out, "unit", v.unit.as_deref());
        opt_attr(out, "displayUnit", v.display_unit.as_deref());
    }
    if matches!(v.var_type, VarType::Real | VarType::Integer | VarType::Enumeration) {
        opt_attr(out, "min", v.min.map(number).as_deref());
        opt_attr(out, "max", v.max.map(number).as_deref());
    }
    if matches!(v.var_type, VarType::Real) {
        opt_attr(out, "nominal", v.nominal.map(double).as_deref());
    }
    if let Some(s) = start {
        let text = match s {
            Value::Real(x) => double(*x),
            Value::Integer(i) => i.to_string(),
            Value::Boolean(b) => b.to_string(),
            Value::String(t) => t.clone(),
            Value::Binary(_) => return Err(unwritable(v, "FMI 2.0 has no Binary start value")),
        };
        attr(out, "start", &text);
    }
    if let Some(d) = v.derivative {
        attr(out, "derivative", &d.to_string());
    }
    flag(out, "reinit", v.reinit);
    out.push_str("/>\n    </ScalarVariable>\n");
    Ok(())
}

impl ModelDescription {
    /// This description as an FMI 2.0 `modelDescription.xml`.
    ///
    /// # Errors
    /// [`SchemaError::UnsupportedFeature`] naming the first variable FMI 2.0 cannot express.
    pub fn to_fmi2_xml(&self) -> Result<String, SchemaError> {
        let mut out = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<fmiModelDescription");
        attr(&mut out, "fmiVersion", "2.0");
        attr(&mut out, "modelName", &self.model_name);
        attr(&mut out, "guid", &self.guid);
        opt_attr(&mut out, "description", self.description.as_deref());
        opt_attr(&mut out, "generationTool", self.generation_tool.as_deref());
        opt_attr(&mut out, "generationDateAndTime", self.generation_date_and_time.as_deref());
        let naming = self.variable_naming_convention.as_deref().filter(|n| *n == "flat" || *n == "structured");
        opt_attr(&mut out, "variableNamingConvention", naming);
        attr(&mut out, "numberOfEventIndicators", &self.number_of_event_indicators.to_string());
        out.push_str(">\n");
        if let Some(me) = &self.model_exchange {
            interface(&mut out, "ModelExchange", me, false);
        }
        if let Some(cs) = &self.co_simulation {
            interface(&mut out, "CoSimulation", cs, true);
        }
        if !self.unit_definitions.is_empty() {
            out.push_str("  <UnitDefinitions>\n");
            for u in &self.unit_definitions {
                out.push_str("    <Unit");
                attr(&mut out, "name", &u.name);
                out.push_str(">\n");
                if let Some(b) = &u.base_unit {
                    out.push_str("      <BaseUnit");
                    for (name, e) in [
                        ("kg", b.kg),
                        ("m", b.m),
                        ("s", b.s),
                        ("A", b.a),
                        ("K", b.k),
                        ("mol", b.mol),
                        ("cd", b.cd),
                        ("rad", b.rad),
                    ] {
                        if e != 0 {
                            attr(&mut out, name, &e.to_string());
                        }
                    }
                    if b.factor != 1.0 {
                        attr(&mut out, "factor", &double(b.factor));
                    }
                    if b.offset != 0.0 {
                        attr(&mut out, "offset", &double(b.offset));
                    }
                    out.push_str("/>\n");
                }
                for d in &u.display_units {
                    out.push_str("      <DisplayUnit");
                    attr(&mut out, "name", &d.name);
                    attr(&mut out, "factor", &double(d.factor));
                    attr(&mut out, "offset", &double(d.offset));
                    out.push_str("/>\n");
                }
                out.push_str("    </Unit>\n");
            }
            out.push_str("  </UnitDefinitions>\n");
        }
        let types: Vec<_> = self.type_definitions.iter().filter(|t| type_element(t.base_type).is_some()).collect();
        if !types.is_empty() {
            out.push_str("  <TypeDefinitions>\n");
            for t in types {
                out.push_str("    <SimpleType");
                attr(&mut out, "name", &t.name);
                opt_attr(&mut out, "description", t.description.as_deref());
                out.push_str(">\n      <");
                out.push_str(type_element(t.base_type).unwrap_or("Real"));
                opt_attr(&mut out, "quantity", t.quantity.as_deref());
                if t.base_type == VarType::Real {
                    opt_attr(&mut out, "unit", t.unit.as_deref());
                    opt_attr(&mut out, "nominal", t.nominal.map(double).as_deref());
                }
                let number = |x: f64| if t.base_type == VarType::Real { double(x) } else { format!("{}", x as i64) };
                if matches!(t.base_type, VarType::Real | VarType::Integer) {
                    opt_attr(&mut out, "min", t.min.map(number).as_deref());
                    opt_attr(&mut out, "max", t.max.map(number).as_deref());
                }
                if t.items.is_empty() {
                    out.push_str("/>\n");
                } else {
                    out.push_str(">\n");
                    for item in &t.items {
                        out.push_str("        <Item");
                        attr(&mut out, "name", &item.name);
                        attr(&mut out, "value", &item.value.to_string());
                        opt_attr(&mut out, "description", item.description.as_deref());
                        out.push_str("/>\n");
                    }
                    out.push_str("      </Enumeration>\n");
                }
                out.push_str("    </SimpleType>\n");
            }
            out.push_str("  </TypeDefinitions>\n");
        }
        if !self.log_categories.is_empty() {
            out.push_str("  <LogCategories>\n");
            for c in &self.log_categories {
                out.push_str("    <Category");
                attr(&mut out, "name", c);
                out.push_str("/>\n");
            }
            out.push_str("  </LogCategories>\n");
        }
        if let Some(de) = &self.default_experiment {
            out.push_str("  <DefaultExperiment");
            for (name, v) in [
                ("startTime", de.start_time),
                ("stopTime", de.stop_time),
                ("tolerance", de.tolerance),
                ("stepSize", de.step_size),
            ] {
                opt_attr(&mut out, name, v.map(double).as_deref());
            }
            out.push_str("/>\n");
        }
        out.push_str("  <ModelVariables>\n");
        for v in &self.variables {
            variable(&mut out, v)?;
        }
        out.push_str("  </ModelVariables>\n  <ModelStructure>\n");
        let ms = &self.model_structure;
        unknowns(&mut out, "Outputs", &ms.outputs);
        unknowns(&mut out, "Derivatives", &ms.derivatives);
        // The description's own list where it is the one FMI 2.0 requires (it carries the
        // dependencies), else the required one (an FMI 1.0 original has none).
        let required = required_initial_unknowns(self);
        let mut own: Vec<usize> = ms.initial_unknowns.iter().map(|u| u.index).collect();
        own.sort_unstable();
        if own == required {
            unknowns(&mut out, "InitialUnknowns", &ms.initial_unknowns);
        } else {
            let list: Vec<Unknown> = required
                .iter()
                .map(|&index| Unknown {
                    index,
                    dependencies: ms
                        .initial_unknowns
                        .iter()
                        .find(|u| u.index == index)
                        .and_then(|u| u.dependencies.clone()),
                })
                .collect();
            unknowns(&mut out, "InitialUnknowns", &list);
        }
        out.push_str("  </ModelStructure>\n</fmiModelDescription>\n");
        Ok(out)
    }

    /// This description without the variables at the 0-based positions `drop`: every index
    /// that pointed past them (derivatives, the model structure and its dependencies) is
    /// renumbered, and an unknown or dependency on a dropped variable is left out.
    pub fn without_variables(&self, drop: &[usize]) -> ModelDescription {
        let mut new_index = vec![None; self.variables.len() + 1];
        let mut next = 0;
        for (i, slot) in new_index.iter_mut().enumerate().skip(1) {
            if !drop.contains(&(i - 1)) {
                next += 1;
                *slot = Some(next);
            }
        }
        let map = |i: usize| new_index.get(i).copied().flatten();
        let list = |l: &[Unknown]| -> Vec<Unknown> {
            l.iter()
                .filter_map(|u| {
                    Some(Unknown {
                        index: map(u.index)?,
                        dependencies: u.dependencies.as_ref().map(|d| d.iter().filter_map(|&j| map(j)).collect()),
                    })
                })
                .collect()
        };
        let mut md = self.clone();
        md.variables = self
            .variables
            .iter()
            .enumerate()
            .filter(|(i, _)| !drop.contains(i))
            .map(|(_, v)| {
                let mut v = v.clone();
                v.derivative = v.derivative.and_then(map);
                v
            })
            .collect();
        md.model_structure.outputs = list(&self.model_structure.outputs);
        md.model_structure.derivatives = list(&self.model_structure.derivatives);
        md.model_structure.initial_unknowns = list(&self.model_structure.initial_unknowns);
        md
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FMI2: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="M &amp; N" guid="{1}" numberOfEventIndicators="1">
  <ModelExchange modelIdentifier="m"/>
  <CoSimulation modelIdentifier="m" canHandleVariableCommunicationStepSize="true"/>
  <UnitDefinitions><Unit name="m/s"><BaseUnit m="1" s="-1"/></Unit></UnitDefinitions>
  <TypeDefinitions><SimpleType name="Mode"><Enumeration><Item name="a" value="1"/><Item name="b" value="2"/></Enumeration></SimpleType></TypeDefinitions>
  <DefaultExperiment startTime="0" stopTime="2.5" tolerance="1e-7"/>
  <ModelVariables>
    <ScalarVariable name="x" valueReference="0" causality="local" variability="continuous" initial="exact"><Real start="1"/></ScalarVariable>
    <ScalarVariable name="der(x)" valueReference="1" causality="local" variability="continuous"><Real derivative="1" unit="m/s"/></ScalarVariable>
    <ScalarVariable name="k" valueReference="2" causality="parameter" variability="fixed" description="a &lt;gain&gt;"><Real start="0.001"/></ScalarVariable>
    <ScalarVariable name="mode" valueReference="3" causality="parameter" variability="fixed"><Enumeration declaredType="Mode" start="2"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="1" causality="output" variability="continuous"><Real/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="5" dependencies="1"/></Outputs>
    <Derivatives><Unknown index="2" dependencies="1 3"/></Derivatives>
    <InitialUnknowns><Unknown index="2"/><Unknown index="5"/></InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>"#;

    #[test]
    fn an_fmi2_description_reads_back_the_same() {
        let md = ModelDescription::parse(FMI2).unwrap();
        let xml = md.to_fmi2_xml().unwrap();
        let back = ModelDescription::parse(&xml).unwrap();
        assert_eq!(back.model_name, "M & N");
        assert_eq!(back.number_of_event_indicators, 1);
        assert_eq!(back.variables.len(), 5);
        for (a, b) in md.variables.iter().zip(&back.variables) {
            assert_eq!(
                (&a.name, a.value_reference, a.causality, a.variability),
                (&b.name, b.value_reference, b.causality, b.variability)
            );
            assert_eq!(
                (&a.start, a.derivative, &a.unit, &a.description),
                (&b.start, b.derivative, &b.unit, &b.description)
            );
        }
        assert_eq!(back.states().len(), 1);
        assert_eq!(back.outputs()[0].name, "y");
        assert_eq!(back.model_structure.derivatives[0].dependencies, Some(vec![1, 3]));
        assert_eq!(back.type_definitions[0].items.len(), 2);
        assert_eq!(back.default_experiment.unwrap().stop_time, Some(2.5));
        assert!(
            back.model_exchange.is_some() && back.co_simulation.unwrap().can_handle_variable_communication_step_size
        );
    }

    #[test]
    fn dropping_a_variable_renumbers_every_index() {
        let md = ModelDescription::parse(FMI2).unwrap().without_variables(&[2]);
        let back = ModelDescription::parse(&md.to_fmi2_xml().unwrap()).unwrap();
        assert_eq!(back.variables.iter().map(|v| v.name.as_str()).collect::<Vec<_>>(), ["x", "der(x)", "mode", "y"]);
        assert_eq!(back.model_structure.outputs[0].index, 4);
        assert_eq!(back.model_structure.derivatives[0].dependencies, Some(vec![1]));
        assert_eq!(back.states()[0].0.name, "x");
    }

    #[test]
    fn what_fmi2_cannot_say_is_refused_naming_the_variable() {
        let mut md = ModelDescription::parse(FMI2).unwrap();
        md.variables[2].negated = true;
        let e = md.to_fmi2_xml().unwrap_err().to_string();
        assert!(e.contains("\"k\"") && e.contains("negated alias"), "{e}");
        md.variables[2].negated = false;
        md.variables[2].var_type = VarType::Binary;
        let e = md.to_fmi2_xml().unwrap_err().to_string();
        assert!(e.contains("\"k\"") && e.contains("Binary"), "{e}");
    }
}
