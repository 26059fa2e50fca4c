//! FMI 1.0 `modelDescription.xml` (Model Exchange 1.0 and Co-Simulation 1.0) onto the
//! version-free [`ModelDescription`]. An FMI 1.0 FMU offers one interface: Co-Simulation when
//! it has an `<Implementation>` (`CoSimulation_StandAlone`; `CoSimulation_Tool` needs its tool),
//! Model Exchange otherwise; the model identifier is an attribute of the root. FMI 1.0 has no
//! model structure: as FMPy does, a variable named `der(x)` is taken as the derivative of the
//! state `x`, in the order of the description (which must give `numberOfContinuousStates` of
//! them), and the outputs are the variables with causality output. Variability `parameter`
//! becomes causality parameter; `fixed="false"` start values are approximate. An `alias` or
//! `negatedAlias` names its base (the variable of the same type and value reference that is no
//! alias); a negated alias is read and set as minus its base (FMPy reads it without the sign).

use super::{
    Attrs, BaseUnit, Causality, DisplayUnit, EnumItem, Initial, InterfaceInfo, ModelDescription, ScalarVariable,
    SchemaError, SimpleType, Unit, Unknown, Variability, err_invalid,
};

#[derive(Default)]
struct Parser {
    md: Option<ModelDescription>,
    model_identifier: String,
    number_of_states: usize,
    co_simulation: Option<InterfaceInfo>,
    /// Per variable: its `alias` attribute is `alias` or `negatedAlias` (`Some(negated)`).
    aliases: Vec<Option<bool>>,
}

/// Parses an FMI 1.0 description.
///
/// # Errors
/// [`SchemaError::Xml`] for malformed XML, [`SchemaError::Invalid`] for a description that
/// breaks FMI 1.0's rules or whose states cannot be told from `der(...)` names.
pub(super) fn parse(xml: &str) -> Result<ModelDescription, SchemaError> {
    let mut p = Parser::default();
    super::walk(xml, |parent, name, attrs| p.open(parent, name, attrs))?;
    p.finish()
}

impl Parser {
    fn md(&mut self, elem: &str) -> Result<&mut ModelDescription, SchemaError> {
        super::opened(&mut self.md, elem)
    }

    fn open(&mut self, parent: Option<&str>, name: &str, a: &Attrs) -> Result<(), SchemaError> {
        match (parent, name) {
            (None, "fmiModelDescription") => {
                self.model_identifier = a.required(name, "modelIdentifier")?;
                self.number_of_states = a.int(name, "numberOfContinuousStates")?.unwrap_or(0);
                let mut md = ModelDescription::from_root(name, a, a.required(name, "fmiVersion")?, "guid")?;
                md.number_of_event_indicators = a.int(name, "numberOfEventIndicators")?.unwrap_or(0);
                self.md = Some(md);
            }
            (None, other) => {
                return Err(err_invalid(format!("root element is <{other}>, expected <fmiModelDescription>")));
            }
            (Some("Implementation"), kind @ ("CoSimulation_StandAlone" | "CoSimulation_Tool")) => {
                self.co_simulation = Some(InterfaceInfo {
                    model_identifier: self.model_identifier.clone(),
                    needs_execution_tool: kind == "CoSimulation_Tool",
                    ..InterfaceInfo::default()
                });
            }
            (Some("CoSimulation_StandAlone" | "CoSimulation_Tool"), "Capabilities") => {
                if let Some(cs) = self.co_simulation.as_mut() {
                    cs.can_handle_variable_communication_step_size =
                        a.bool(name, "canHandleVariableCommunicationStepSize")?;
                    cs.can_interpolate_inputs = a.bool(name, "canInterpolateInputs")?;
                    cs.max_output_derivative_order = a.int(name, "maxOutputDerivativeOrder")?.unwrap_or(0);
                    cs.can_be_instantiated_only_once_per_process =
                        a.bool(name, "canBeInstantiatedOnlyOncePerProcess")?;
                    cs.can_not_use_memory_management_functions = a.bool(name, "canNotUseMemoryManagementFunctions")?;
                }
            }
            (Some("UnitDefinitions"), "BaseUnit") => {
                let unit = Unit { name: a.required(name, "unit")?, base_unit: None::<BaseUnit>, display_units: vec![] };
                self.md(name)?.unit_definitions.push(unit);
            }
            (Some("BaseUnit"), "DisplayUnitDefinition") => {
                let du = DisplayUnit {
                    name: a.required(name, "displayUnit")?,
                    factor: a.f64(name, "gain")?.unwrap_or(1.0),
                    offset: a.f64(name, "offset")?.unwrap_or(0.0),
                };
                if let Some(unit) = self.md(name)?.unit_definitions.last_mut() {
                    unit.display_units.push(du);
                }
            }
            (Some("TypeDefinitions"), "Type") => {
                let st = SimpleType::named(name, a)?;
                self.md(name)?.type_definitions.push(st);
            }
            (
                Some("Type"),
                type_elem @ ("RealType" | "IntegerType" | "BooleanType" | "StringType" | "EnumerationType"),
            ) => {
                if let Some(st) = self.md(name)?.type_definitions.last_mut() {
                    st.apply(super::var_type(type_elem.trim_end_matches("Type")), name, a)?;
                }
            }
            (Some("EnumerationType"), "Item") => {
                let md = self.md(name)?;
                if let Some(st) = md.type_definitions.last_mut() {
                    // FMI 1.0 items are numbered 1, 2, ... in their order.
                    let value = st.items.len() as i64 + 1;
                    st.items.push(EnumItem {
                        name: a.required(name, "name")?,
                        value,
                        description: a.string("description"),
                    });
                }
            }
            (Some("fmiModelDescription"), "DefaultExperiment") => {
                let de = super::default_experiment(name, a)?;
                self.md(name)?.default_experiment = Some(de);
            }
            (Some("ModelVariables"), "ScalarVariable") => {
                self.aliases.push(match a.get("alias") {
                    Some("alias") => Some(false),
                    Some("negatedAlias") => Some(true),
                    _ => None,
                });
                let var = scalar_variable(a)?;
                self.md(name)?.variables.push(var);
            }
            (Some("ScalarVariable"), elem @ ("Real" | "Integer" | "Boolean" | "String" | "Enumeration")) => {
                let md = self.md(name)?;
                let var = md.variables.last_mut().ok_or_else(|| err_invalid("type element outside a variable"))?;
                apply_type_element(var, elem, a)?;
            }
            _ => {}
        }
        Ok(())
    }

    fn finish(self) -> Result<ModelDescription, SchemaError> {
        let mut md = self.md.ok_or_else(|| err_invalid("no <fmiModelDescription> root element"))?;
        match self.co_simulation {
            Some(cs) => md.co_simulation = Some(cs),
            None => {
                md.model_exchange =
                    Some(InterfaceInfo { model_identifier: self.model_identifier.clone(), ..InterfaceInfo::default() })
            }
        }
        let bases: std::collections::HashMap<(super::VarType, u32), String> = md
            .variables
            .iter()
            .zip(&self.aliases)
            .filter(|(_, alias)| alias.is_none())
            .map(|(v, _)| ((v.var_type, v.value_reference), v.name.clone()))
            .collect();
        for (var, alias) in md.variables.iter_mut().zip(&self.aliases) {
            if let Some(negated) = *alias {
                var.alias_of = bases.get(&(var.var_type, var.value_reference)).cloned();
                var.negated = negated;
            }
        }
        // States from der(x) names, in the order written; an x that is an alias stands for its
        // base, and a state named through several aliases counts once (its derivative the one
        // that is no alias, else the first).
        let index_of: std::collections::HashMap<&str, usize> = md
            .variables
            .iter()
            .enumerate()
            .filter(|(_, v)| !v.negated)
            .map(|(k, v)| (v.name.as_str(), k))
            .rev()
            .collect();
        let mut derivatives: Vec<(usize, usize)> = vec![];
        for (k, (var, alias)) in md.variables.iter().zip(&self.aliases).enumerate() {
            if var.negated {
                continue;
            }
            let Some(state) = var.name.strip_prefix("der(").and_then(|s| s.strip_suffix(')')) else { continue };
            let Some(&s) = index_of.get(state) else { continue };
            let s = md.variables[s].alias_of.as_deref().and_then(|b| index_of.get(b)).copied().unwrap_or(s);
            match derivatives.iter_mut().find(|(_, state)| *state == s) {
                Some(entry) if alias.is_none() && self.aliases[entry.0].is_some() => entry.0 = k,
                Some(_) => {}
                None => derivatives.push((k, s)),
            }
        }
        if derivatives.len() != self.number_of_states {
            return Err(err_invalid(format!(
                "numberOfContinuousStates is {} but {} variables are named der(<state>): fmucal tells an FMI 1.0 FMU's states by those names, as FMPy does",
                self.number_of_states,
                derivatives.len()
            )));
        }
        for (der, state) in &derivatives {
            md.variables[*der].derivative = Some(state + 1);
            md.model_structure.derivatives.push(Unknown { index: der + 1, dependencies: None });
        }
        md.model_structure.outputs = md
            .variables
            .iter()
            .enumerate()
            .filter(|(_, v)| v.causality == Causality::Output)
            .map(|(k, _)| Unknown { index: k + 1, dependencies: None })
            .collect();
        super::finish(&mut md)?;
        Ok(md)
    }
}

fn scalar_variable(a: &Attrs) -> Result<ScalarVariable, SchemaError> {
    let name = a.required("ScalarVariable", "name")?;
    let ctx = |msg: String| err_invalid(format!("variable {name:?}: {msg}"));
    let value_reference = super::value_reference(a, &name)?;
    let variability_text = a.get("variability").unwrap_or("continuous");
    let variability = match variability_text {
        "constant" => Variability::Constant,
        "parameter" => Variability::Fixed,
        "discrete" => Variability::Discrete,
        "continuous" => Variability::Continuous,
        other => return Err(ctx(format!("unknown variability {other:?}"))),
    };
    let causality = match (a.get("causality").unwrap_or("internal"), variability_text) {
        ("input", _) => Causality::Input,
        ("output", _) => Causality::Output,
        ("internal" | "none", "parameter") => Causality::Parameter,
        ("internal" | "none", _) => Causality::Local,
        (other, _) => return Err(ctx(format!("unknown causality {other:?}"))),
    };
    Ok(ScalarVariable::new(name, value_reference, a.string("description"), causality, variability, None))
}

/// The type element as FMI 2.0 reads it (the same elements and attributes), then `initial` from
/// FMI 1.0's `fixed`.
fn apply_type_element(var: &mut ScalarVariable, elem: &str, a: &Attrs) -> Result<(), SchemaError> {
    super::apply_type_element(var, elem, a)?;
    let name = var.name.clone();
    let ctx = super::in_variable(&name);
    // FMI 1.0: a start value is exact unless fixed="false"; without one, calculated.
    let fixed = a.bool(elem, "fixed").map_err(ctx)? || a.get("fixed").is_none();
    var.initial = match (&var.start, fixed) {
        (None, _) => (var.causality != Causality::Input && var.variability != Variability::Constant)
            .then_some(Initial::Calculated),
        (Some(_), false) => Some(Initial::Approx),
        (Some(_), true) => Some(Initial::Exact),
    };
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const ME: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="1.0" modelName="M" modelIdentifier="M" guid="{g}" numberOfContinuousStates="2" numberOfEventIndicators="1">
  <UnitDefinitions><BaseUnit unit="rad"><DisplayUnitDefinition displayUnit="deg" gain="57.29577951308232"/></BaseUnit></UnitDefinitions>
  <TypeDefinitions>
    <Type name="Angle"><RealType quantity="Angle" unit="rad" min="-7"/></Type>
    <Type name="Mode"><EnumerationType><Item name="off"/><Item name="on"/></EnumerationType></Type>
  </TypeDefinitions>
  <DefaultExperiment startTime="0" stopTime="3" tolerance="1e-6"/>
  <ModelVariables>
    <ScalarVariable name="phi" valueReference="0" causality="output"><Real declaredType="Angle" start="1" fixed="true"/></ScalarVariable>
    <ScalarVariable name="w" valueReference="1"><Real start="0" fixed="false"/></ScalarVariable>
    <ScalarVariable name="der(phi)" valueReference="2"><Real/></ScalarVariable>
    <ScalarVariable name="der(w)" valueReference="3"><Real/></ScalarVariable>
    <ScalarVariable name="c" valueReference="4" variability="parameter"><Real start="0.1"/></ScalarVariable>
    <ScalarVariable name="minusPhi" valueReference="0" alias="negatedAlias"><Real/></ScalarVariable>
    <ScalarVariable name="mode" valueReference="0" variability="parameter"><Enumeration declaredType="Mode" start="2"/></ScalarVariable>
    <ScalarVariable name="u" valueReference="5" causality="input"><Real start="0"/></ScalarVariable>
  </ModelVariables>
</fmiModelDescription>"#;

    #[test]
    fn a_1_0_model_exchange_description_maps_onto_the_version_free_structs() {
        let md = ModelDescription::parse(ME).unwrap();
        assert_eq!(md.fmi_version, "1.0");
        assert_eq!(md.model_exchange.as_ref().unwrap().model_identifier, "M");
        assert!(md.co_simulation.is_none());
        let states: Vec<(&str, &str)> = md.states().iter().map(|(s, d)| (s.name.as_str(), d.name.as_str())).collect();
        assert_eq!(states, [("phi", "der(phi)"), ("w", "der(w)")]);
        assert_eq!(md.outputs().iter().map(|v| v.name.as_str()).collect::<Vec<_>>(), ["phi"]);
        let c = md.variable("c").unwrap();
        assert_eq!((c.causality, c.variability), (Causality::Parameter, Variability::Fixed));
        assert!(c.settable_before_init());
        assert_eq!(md.variable("w").unwrap().initial, Some(Initial::Approx));
        assert_eq!(md.variable("phi").unwrap().unit.as_deref(), Some("rad"));
        let minus = md.variable("minusPhi").unwrap();
        assert!(minus.negated, "a negated alias reads with the wrong sign");
        assert_eq!(minus.alias_of.as_deref(), Some("phi"));
        assert_eq!(md.variable("mode").unwrap().alias_of, None, "an Enumeration is no alias of a Real");
        let mode = md.type_definitions.iter().find(|t| t.name == "Mode").unwrap();
        assert_eq!(mode.items.iter().map(|i| i.value).collect::<Vec<_>>(), [1, 2]);
        assert_eq!(md.default_experiment.as_ref().unwrap().stop_time, Some(3.0));
    }

    #[test]
    fn an_implementation_makes_a_co_simulation_fmu() {
        let cs = ME.replace(
            "<DefaultExperiment",
            r#"<Implementation><CoSimulation_StandAlone><Capabilities canHandleVariableCommunicationStepSize="true"/></CoSimulation_StandAlone></Implementation><DefaultExperiment"#,
        );
        let md = ModelDescription::parse(&cs).unwrap();
        assert!(md.model_exchange.is_none());
        let info = md.co_simulation.as_ref().unwrap();
        assert_eq!(info.model_identifier, "M");
        assert!(info.can_handle_variable_communication_step_size && !info.needs_execution_tool);
        let tool = cs.replace("CoSimulation_StandAlone", "CoSimulation_Tool");
        assert!(ModelDescription::parse(&tool).unwrap().co_simulation.unwrap().needs_execution_tool);
    }

    #[test]
    fn states_that_cannot_be_told_from_der_names_are_invalid() {
        let xml = ME.replace("numberOfContinuousStates=\"2\"", "numberOfContinuousStates=\"3\"");
        let err = ModelDescription::parse(&xml).unwrap_err().to_string();
        assert!(err.contains("numberOfContinuousStates is 3 but 2 variables are named der(<state>)"), "{err}");
    }
}
