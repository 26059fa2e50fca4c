//! Parses a `modelDescription.xml` into plain structs, one [`ModelDescription`] whatever the FMI
//! version: FMI 2.0 here (specification section 2.2), FMI 3.0 in [`fmi3`], which maps its typed
//! variables, arrays and value-reference-based model structure onto the same structs, and FMI
//! 1.0 in [`fmi1`] (states from `der(x)` names, as FMPy reads them). Pure code with no
//! `unsafe`: attributes, capability flags, units, type definitions, scalar variables (with
//! declared types resolved), model structure and default experiment. Other versions are
//! rejected with [`SchemaError::UnsupportedVersion`].
#![forbid(unsafe_code)]

mod fmi1;
mod fmi3;
mod write;

pub use fmi3::MAX_VARIABLES;

use quick_xml::Reader;
use quick_xml::events::{BytesStart, Event};
use std::collections::HashMap;

use serde::Serialize;

/// Why a model description could not be read.
#[derive(Debug, thiserror::Error)]
pub enum SchemaError {
    /// The XML is not well formed (or ends early).
    #[error("malformed modelDescription.xml at byte {position}: {message}")]
    Xml { position: u64, message: String },
    /// The description is valid XML but breaks an FMI 2.0 rule.
    #[error("invalid modelDescription.xml: {0}")]
    Invalid(String),
    /// `fmiVersion` is not 1.0, 2.0 or 3.0.
    #[error("FMI {0} FMUs are not supported (fmucal reads FMI 1.0, 2.0 and 3.0)")]
    UnsupportedVersion(String),
    /// The FMU needs an FMI feature fmucal does not implement.
    #[error("{0}")]
    UnsupportedFeature(String),
}

/// Where a variable's value comes from (FMI 2.0 section 2.2.7, `causality`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub enum Causality {
    Parameter,
    CalculatedParameter,
    Input,
    Output,
    Local,
    Independent,
}

/// When a variable may change (`variability`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub enum Variability {
    Constant,
    Fixed,
    Tunable,
    Discrete,
    Continuous,
}

/// How a variable is initialised (`initial`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub enum Initial {
    Exact,
    Approx,
    Calculated,
}

/// The base type of a scalar variable (FMI 3.0's types by kind: Float32 and Float64 are Real,
/// every integer width is Integer; [`ScalarVariable::fmi3`] keeps the exact type).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum VarType {
    Real,
    Integer,
    Boolean,
    String,
    Enumeration,
    /// FMI 3.0 only.
    Binary,
    /// FMI 3.0 only.
    Clock,
}

/// The exact type of an FMI 3.0 variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Fmi3Type {
    Float32,
    Float64,
    Int8,
    UInt8,
    Int16,
    UInt16,
    Int32,
    UInt32,
    Int64,
    UInt64,
    Boolean,
    String,
    Binary,
    Enumeration,
    Clock,
}

/// How fmucal reaches a variable of an FMI 3.0 FMU. An array is listed as one variable per
/// element (`k[2]`, `m[1,3]`), each with a value reference of fmucal's own
/// ([`ScalarVariable::value_reference`]); this says which array it belongs to and where.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Fmi3Storage {
    /// The FMI 3.0 type.
    #[serde(rename = "type")]
    pub ty: Fmi3Type,
    /// The value reference in the FMU (the whole array's, for an element).
    pub value_reference: u32,
    /// For an element: its position in the array, flattened in row-major order (0-based).
    pub element: Option<usize>,
    /// The array's dimensions (empty for a scalar).
    pub dimensions: Vec<usize>,
}

impl Fmi3Storage {
    /// How many values the variable holds (1 for a scalar).
    pub fn len(&self) -> usize {
        self.dimensions.iter().product()
    }

    /// Whether the variable holds no value (an array with a zero dimension).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A start value, typed by the variable's base type.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Value {
    Real(f64),
    Integer(i64),
    Boolean(bool),
    String(String),
    /// An FMI 3.0 Binary start value (written in hex in the description), shown as hex.
    #[serde(serialize_with = "serialize_hex")]
    Binary(Vec<u8>),
}

/// Lower-case hex digits of `bytes`, two per byte.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// The bytes of a hex text (an optional `0x` prefix, white space ignored), as FMI 3.0 writes
/// Binary start values; `None` for anything else.
pub fn parse_hex(text: &str) -> Option<Vec<u8>> {
    let text = text.trim();
    let text = text.strip_prefix("0x").or_else(|| text.strip_prefix("0X")).unwrap_or(text);
    let digits: Vec<u8> = text.bytes().filter(|b| !b.is_ascii_whitespace()).collect();
    if digits.len() % 2 != 0 || !digits.iter().all(u8::is_ascii_hexdigit) {
        return None;
    }
    let value = |d: u8| (d as char).to_digit(16).unwrap_or(0) as u8;
    Some(digits.chunks(2).map(|pair| value(pair[0]) << 4 | value(pair[1])).collect())
}

fn serialize_hex<S: serde::Serializer>(bytes: &[u8], s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&hex(bytes))
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Real(v) => write!(f, "{v}"),
            Value::Integer(v) => write!(f, "{v}"),
            Value::Boolean(v) => write!(f, "{v}"),
            Value::String(v) => write!(f, "{v:?}"),
            Value::Binary(v) => write!(f, "0x{}", hex(v)),
        }
    }
}

/// One `ScalarVariable`. Attributes missing on the variable are taken from its declared type.
#[derive(Debug, Clone, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct ScalarVariable {
    pub name: String,
    pub value_reference: u32,
    pub description: Option<String>,
    pub causality: Causality,
    pub variability: Variability,
    /// `initial` as written in the file; see [`ScalarVariable::effective_initial`].
    pub initial: Option<Initial>,
    pub var_type: VarType,
    pub declared_type: Option<String>,
    pub start: Option<Value>,
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub nominal: Option<f64>,
    pub unit: Option<String>,
    /// 1-based index of the state this variable is the derivative of.
    pub derivative: Option<usize>,
    pub reinit: bool,
    /// The unit in which tools show the value (`displayUnit`); values stay in `unit`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub display_unit: Option<String>,
    /// For an alias, the variable whose value it shares: an FMI 3.0 `<Alias>` element, an FMI
    /// 1.0 `alias`/`negatedAlias`, or an FMI 2.0 variable with the value reference of an
    /// earlier one. An alias is read and set through its base's value reference.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alias_of: Option<String>,
    /// An FMI 1.0 negated alias: its value is minus its base's (for a Boolean, the negation).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub negated: bool,
    /// FMI 3.0 only: the exact type, and the array an element belongs to.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fmi3: Option<Fmi3Storage>,
}

impl ScalarVariable {
    /// `initial`, with the default of FMI 2.0 Table 2.2.7 applied when the file omits it.
    pub fn effective_initial(&self) -> Option<Initial> {
        if self.initial.is_some() {
            return self.initial;
        }
        match (self.causality, self.variability) {
            (_, Variability::Constant) => Some(Initial::Exact),
            (Causality::Parameter, _) => Some(Initial::Exact),
            (Causality::CalculatedParameter, _) => Some(Initial::Calculated),
            (Causality::Output | Causality::Local, _) => Some(Initial::Calculated),
            (Causality::Input | Causality::Independent, _) => None,
        }
    }

    /// Whether the environment may set this variable before initialisation (FMI 2.0 section
    /// 4.2.4/3.2.3: variables with a start value that are not constants or calculated).
    pub fn settable_before_init(&self) -> bool {
        self.variability != Variability::Constant
            && (self.causality == Causality::Input
                || matches!(self.effective_initial(), Some(Initial::Exact | Initial::Approx)))
    }
}

/// Capability flags of the `ModelExchange` or `CoSimulation` element.
#[derive(Debug, Clone, Default, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct InterfaceInfo {
    pub model_identifier: String,
    pub needs_execution_tool: bool,
    pub can_be_instantiated_only_once_per_process: bool,
    pub can_not_use_memory_management_functions: bool,
    pub can_get_and_set_fmu_state: bool,
    pub can_serialize_fmu_state: bool,
    pub provides_directional_derivative: bool,
    /// Model Exchange only.
    pub completed_integrator_step_not_needed: bool,
    /// Co-Simulation only.
    pub can_handle_variable_communication_step_size: bool,
    pub can_interpolate_inputs: bool,
    pub max_output_derivative_order: u32,
    pub can_run_asynchronuously: bool,
}

/// A `BaseUnit`: exponents of the SI base units plus factor and offset.
#[derive(Debug, Clone, Default, Serialize)]
pub struct BaseUnit {
    pub kg: i32,
    pub m: i32,
    pub s: i32,
    #[serde(rename = "A")]
    pub a: i32,
    #[serde(rename = "K")]
    pub k: i32,
    pub mol: i32,
    pub cd: i32,
    pub rad: i32,
    pub factor: f64,
    pub offset: f64,
}

/// A `DisplayUnit` of a unit.
#[derive(Debug, Clone, Serialize)]
pub struct DisplayUnit {
    pub name: String,
    pub factor: f64,
    pub offset: f64,
}

/// A `Unit` of `UnitDefinitions`.
#[derive(Debug, Clone, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Unit {
    pub name: String,
    pub base_unit: Option<BaseUnit>,
    pub display_units: Vec<DisplayUnit>,
}

/// An `Item` of an enumeration type.
#[derive(Debug, Clone, Serialize)]
pub struct EnumItem {
    pub name: String,
    pub value: i64,
    pub description: Option<String>,
}

/// A `SimpleType` of `TypeDefinitions`.
#[derive(Debug, Clone, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct SimpleType {
    pub name: String,
    pub description: Option<String>,
    pub base_type: VarType,
    pub quantity: Option<String>,
    pub unit: Option<String>,
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub nominal: Option<f64>,
    pub items: Vec<EnumItem>,
}

/// `DefaultExperiment`.
#[derive(Debug, Clone, Default, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct DefaultExperiment {
    pub start_time: Option<f64>,
    pub stop_time: Option<f64>,
    pub tolerance: Option<f64>,
    pub step_size: Option<f64>,
}

/// An `Unknown` of `ModelStructure`: 1-based variable index and its dependencies.
#[derive(Debug, Clone, Serialize)]
pub struct Unknown {
    pub index: usize,
    pub dependencies: Option<Vec<usize>>,
}

/// `ModelStructure`.
#[derive(Debug, Clone, Default, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct ModelStructure {
    pub outputs: Vec<Unknown>,
    pub derivatives: Vec<Unknown>,
    pub initial_unknowns: Vec<Unknown>,
}

/// The parsed `fmiModelDescription`.
#[derive(Debug, Clone, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct ModelDescription {
    pub fmi_version: String,
    pub model_name: String,
    pub guid: String,
    pub description: Option<String>,
    pub generation_tool: Option<String>,
    pub generation_date_and_time: Option<String>,
    pub variable_naming_convention: Option<String>,
    pub number_of_event_indicators: usize,
    pub model_exchange: Option<InterfaceInfo>,
    pub co_simulation: Option<InterfaceInfo>,
    pub unit_definitions: Vec<Unit>,
    pub type_definitions: Vec<SimpleType>,
    pub log_categories: Vec<String>,
    pub default_experiment: Option<DefaultExperiment>,
    pub variables: Vec<ScalarVariable>,
    pub model_structure: ModelStructure,
}

impl ModelDescription {
    /// The root element's attributes every version has (`token` names the attribute holding
    /// the GUID: `guid`, or `instantiationToken` in FMI 3.0), with nothing else read yet.
    fn from_root(elem: &str, a: &Attrs, fmi_version: String, token: &str) -> Result<Self, SchemaError> {
        Ok(ModelDescription {
            fmi_version,
            model_name: a.required(elem, "modelName")?,
            guid: a.required(elem, token)?,
            description: a.string("description"),
            generation_tool: a.string("generationTool"),
            generation_date_and_time: a.string("generationDateAndTime"),
            variable_naming_convention: a.string("variableNamingConvention"),
            number_of_event_indicators: 0,
            model_exchange: None,
            co_simulation: None,
            unit_definitions: vec![],
            type_definitions: vec![],
            log_categories: vec![],
            default_experiment: None,
            variables: vec![],
            model_structure: ModelStructure::default(),
        })
    }

    /// Parses the text of a `modelDescription.xml`.
    ///
    /// # Errors
    /// [`SchemaError::Xml`] for malformed XML, [`SchemaError::UnsupportedVersion`] for FMI 1.0/3.0,
    /// [`SchemaError::Invalid`] for a description that breaks FMI 2.0's rules.
    pub fn parse(xml: &str) -> Result<Self, SchemaError> {
        match fmi3::root_version(xml).as_deref() {
            Some(v) if v.starts_with("3.") => fmi3::parse(xml),
            Some(v) if v.starts_with("1.") => fmi1::parse(xml),
            _ => Parser::default().run(xml),
        }
    }

    /// The variable with this name.
    pub fn variable(&self, name: &str) -> Option<&ScalarVariable> {
        self.variables.iter().find(|v| v.name == name)
    }

    /// The variable an alias shares its value with (the variable itself if it is no alias).
    pub fn base_of<'a>(&'a self, v: &'a ScalarVariable) -> &'a ScalarVariable {
        v.alias_of.as_deref().and_then(|base| self.variable(base)).unwrap_or(v)
    }

    /// The elements of the FMI 3.0 array (or alias of one) called `name`, in row-major order;
    /// `None` if no array has that name.
    pub fn array_elements(&self, name: &str) -> Option<Vec<&ScalarVariable>> {
        let elements: Vec<&ScalarVariable> = self
            .variables
            .iter()
            .filter(|v| {
                v.fmi3.as_ref().is_some_and(|s| s.element.is_some())
                    && v.name.strip_prefix(name).is_some_and(|rest| rest.starts_with('[') && !rest[1..].contains('['))
            })
            .collect();
        (!elements.is_empty()).then_some(elements)
    }

    /// Why no variable is called `name`, for an error message: "unknown variable …", or, for
    /// an FMI 3.0 array, that it must be named by element or that the index is out of range.
    pub fn unknown_variable(&self, name: &str) -> String {
        let base = name.split_once('[').map_or(name, |(b, _)| b);
        let elements = self.array_elements(base).unwrap_or_default();
        let (Some(first), Some(last)) = (elements.first(), elements.last()) else {
            return format!("unknown variable {}", crate::quote::quote_user_text(name));
        };
        let dims = first.fmi3.as_ref().map(|s| s.dimensions.clone()).unwrap_or_default();
        let shape = dims.iter().map(usize::to_string).collect::<Vec<_>>().join("×");
        if base == name {
            format!("{name} is an array of {shape}: name one element, {} to {}", first.name, last.name)
        } else {
            format!("{name}: index out of range; {base} is an array of {shape} ({} to {})", first.name, last.name)
        }
    }

    /// A variable's unit: its own, else its declared type's.
    pub fn unit_of<'a>(&'a self, v: &'a ScalarVariable) -> Option<&'a str> {
        v.unit.as_deref().or_else(|| {
            let t = v.declared_type.as_ref()?;
            self.type_definitions.iter().find(|d| &d.name == t)?.unit.as_deref()
        })
    }

    /// Continuous states in the order of `ModelStructure/Derivatives` (the order of the state
    /// vector in `fmi2GetContinuousStates`), as (state, derivative) pairs.
    pub fn states(&self) -> Vec<(&ScalarVariable, &ScalarVariable)> {
        self.model_structure
            .derivatives
            .iter()
            .filter_map(|u| {
                let der = &self.variables[u.index - 1];
                der.derivative.map(|s| (&self.variables[s - 1], der))
            })
            .collect()
    }

    /// Variables with causality output, in `ModelStructure/Outputs` order.
    pub fn outputs(&self) -> Vec<&ScalarVariable> {
        self.model_structure.outputs.iter().map(|u| &self.variables[u.index - 1]).collect()
    }
}

#[derive(Default)]
struct Parser {
    md: Option<ModelDescription>,
}

fn err_invalid(msg: impl Into<String>) -> SchemaError {
    SchemaError::Invalid(msg.into())
}

/// Attributes of one element as (name, unescaped value) pairs.
struct Attrs(Vec<(String, String)>);

impl Attrs {
    fn read(e: &BytesStart<'_>, position: u64) -> Result<Self, SchemaError> {
        let mut out = Vec::new();
        for attr in e.attributes() {
            let attr = attr.map_err(|err| SchemaError::Xml { position, message: err.to_string() })?;
            let key = attr.key.as_ref().to_string();
            let value = attr
                .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                .map_err(|err| SchemaError::Xml { position, message: err.to_string() })?
                .into_owned();
            out.push((key, value));
        }
        Ok(Attrs(out))
    }

    fn get(&self, key: &str) -> Option<&str> {
        self.0.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    fn string(&self, key: &str) -> Option<String> {
        self.get(key).map(str::to_owned)
    }

    fn required(&self, elem: &str, key: &str) -> Result<String, SchemaError> {
        self.string(key).ok_or_else(|| err_invalid(format!("<{elem}> has no {key} attribute")))
    }

    fn f64(&self, elem: &str, key: &str) -> Result<Option<f64>, SchemaError> {
        self.get(key)
            .map(|v| {
                v.trim().parse::<f64>().map_err(|_| err_invalid(format!("<{elem}> {key}=\"{v}\" is not a number")))
            })
            .transpose()
    }

    fn int<T: std::str::FromStr>(&self, elem: &str, key: &str) -> Result<Option<T>, SchemaError> {
        self.get(key)
            .map(|v| {
                v.trim().parse::<T>().map_err(|_| err_invalid(format!("<{elem}> {key}=\"{v}\" is not an integer")))
            })
            .transpose()
    }

    fn bool(&self, elem: &str, key: &str) -> Result<bool, SchemaError> {
        match self.get(key).map(str::trim) {
            None | Some("false") | Some("0") => Ok(false),
            Some("true") | Some("1") => Ok(true),
            Some(v) => Err(err_invalid(format!("<{elem}> {key}=\"{v}\" is not a boolean"))),
        }
    }
}

/// Reads `xml` element by element, calling `open(parent, name, attributes)` for each start or
/// empty element (`parent` is the enclosing element's name, `None` for the root).
///
/// # Errors
/// [`SchemaError::Xml`] for malformed XML or a document that ends inside an element, and
/// whatever `open` returns.
fn walk(
    xml: &str,
    mut open: impl FnMut(Option<&str>, &str, &Attrs) -> Result<(), SchemaError>,
) -> Result<(), SchemaError> {
    let mut reader = Reader::from_str(xml);
    reader.config_mut().trim_text(true);
    let mut path: Vec<String> = vec![];
    loop {
        let position = reader.buffer_position();
        let event = reader.read_event().map_err(|e| SchemaError::Xml { position, message: e.to_string() })?;
        match event {
            Event::Start(e) => {
                let name = e.name().as_ref().to_string();
                open(path.last().map(String::as_str), &name, &Attrs::read(&e, position)?)?;
                path.push(name);
            }
            Event::Empty(e) => {
                let name = e.name().as_ref().to_string();
                open(path.last().map(String::as_str), &name, &Attrs::read(&e, position)?)?;
            }
            Event::End(_) => {
                path.pop();
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if !path.is_empty() {
        return Err(SchemaError::Xml {
            position: xml.len() as u64,
            message: format!("document ends inside <{}>", path.join("/")),
        });
    }
    Ok(())
}

/// A `BaseUnit` element of FMI 2.0 and 3.0.
fn base_unit(elem: &str, a: &Attrs) -> Result<BaseUnit, SchemaError> {
    Ok(BaseUnit {
        kg: a.int(elem, "kg")?.unwrap_or(0),
        m: a.int(elem, "m")?.unwrap_or(0),
        s: a.int(elem, "s")?.unwrap_or(0),
        a: a.int(elem, "A")?.unwrap_or(0),
        k: a.int(elem, "K")?.unwrap_or(0),
        mol: a.int(elem, "mol")?.unwrap_or(0),
        cd: a.int(elem, "cd")?.unwrap_or(0),
        rad: a.int(elem, "rad")?.unwrap_or(0),
        factor: a.f64(elem, "factor")?.unwrap_or(1.0),
        offset: a.f64(elem, "offset")?.unwrap_or(0.0),
    })
}

/// A `DisplayUnit` element of FMI 2.0 and 3.0.
fn display_unit(elem: &str, a: &Attrs) -> Result<DisplayUnit, SchemaError> {
    Ok(DisplayUnit {
        name: a.required(elem, "name")?,
        factor: a.f64(elem, "factor")?.unwrap_or(1.0),
        offset: a.f64(elem, "offset")?.unwrap_or(0.0),
    })
}

/// The `DefaultExperiment` element of every version.
/// The description a reader has opened at `<fmiModelDescription>`, for a child element `elem`.
fn opened<'a>(md: &'a mut Option<ModelDescription>, elem: &str) -> Result<&'a mut ModelDescription, SchemaError> {
    md.as_mut().ok_or_else(|| err_invalid(format!("<{elem}> outside <fmiModelDescription>")))
}

/// An enumeration's `<Item>` with the value attribute FMI 2.0 and 3.0 require.
fn enum_item(elem: &str, a: &Attrs) -> Result<EnumItem, SchemaError> {
    Ok(EnumItem {
        name: a.required(elem, "name")?,
        value: a.int(elem, "value")?.ok_or_else(|| err_invalid("<Item> has no value attribute"))?,
        description: a.string("description"),
    })
}

fn default_experiment(elem: &str, a: &Attrs) -> Result<DefaultExperiment, SchemaError> {
    Ok(DefaultExperiment {
        start_time: a.f64(elem, "startTime")?,
        stop_time: a.f64(elem, "stopTime")?,
        tolerance: a.f64(elem, "tolerance")?,
        step_size: a.f64(elem, "stepSize")?,
    })
}

impl Parser {
    fn run(mut self, xml: &str) -> Result<ModelDescription, SchemaError> {
        walk(xml, |parent, name, attrs| self.open(parent, name, attrs))?;
        let mut md = self.md.ok_or_else(|| err_invalid("no <fmiModelDescription> root element"))?;
        finish(&mut md)?;
        Ok(md)
    }

    fn md(&mut self, elem: &str) -> Result<&mut ModelDescription, SchemaError> {
        opened(&mut self.md, elem)
    }

    fn open(&mut self, parent: Option<&str>, name: &str, a: &Attrs) -> Result<(), SchemaError> {
        match (parent, name) {
            (None, "fmiModelDescription") => {
                let version = a.required(name, "fmiVersion")?;
                if !version.starts_with("2.") {
                    let major = version.split('.').next().unwrap_or(&version);
                    return Err(SchemaError::UnsupportedVersion(format!("{major}.0")));
                }
                let mut md = ModelDescription::from_root(name, a, version, "guid")?;
                md.number_of_event_indicators = a.int(name, "numberOfEventIndicators")?.unwrap_or(0);
                self.md = Some(md);
            }
            (None, other) => {
                // FMI 1.0 also uses fmiModelDescription; FMI 3.0 too. Anything else is not an FMU.
                return Err(err_invalid(format!("root element is <{other}>, expected <fmiModelDescription>")));
            }
            (Some("fmiModelDescription"), "ModelExchange" | "CoSimulation") => {
                let info = interface_info(name, a)?;
                let md = self.md(name)?;
                if name == "ModelExchange" {
                    md.model_exchange = Some(info);
                } else {
                    md.co_simulation = Some(info);
                }
            }
            (Some("UnitDefinitions"), "Unit") => {
                let unit = Unit { name: a.required(name, "name")?, base_unit: None, display_units: vec![] };
                self.md(name)?.unit_definitions.push(unit);
            }
            (Some("Unit"), "BaseUnit") => {
                let base = base_unit(name, a)?;
                if let Some(unit) = self.md(name)?.unit_definitions.last_mut() {
                    unit.base_unit = Some(base);
                }
            }
            (Some("Unit"), "DisplayUnit") => {
                let du = display_unit(name, a)?;
                if let Some(unit) = self.md(name)?.unit_definitions.last_mut() {
                    unit.display_units.push(du);
                }
            }
            (Some("TypeDefinitions"), "SimpleType") => {
                let st = SimpleType::named(name, a)?;
                self.md(name)?.type_definitions.push(st);
            }
            (Some("SimpleType"), "Real" | "Integer" | "Boolean" | "String" | "Enumeration") => {
                if let Some(st) = self.md(name)?.type_definitions.last_mut() {
                    st.apply(var_type(name), name, a)?;
                }
            }
            (Some("Enumeration"), "Item") => {
                let item = enum_item(name, a)?;
                if let Some(st) = self.md(name)?.type_definitions.last_mut() {
                    st.items.push(item);
                }
            }
            (Some("LogCategories"), "Category") => {
                let cat = a.required(name, "name")?;
                self.md(name)?.log_categories.push(cat);
            }
            (Some("fmiModelDescription"), "DefaultExperiment") => {
                let de = default_experiment(name, a)?;
                self.md(name)?.default_experiment = Some(de);
            }
            (Some("ModelVariables"), "ScalarVariable") => {
                let var = scalar_variable(a)?;
                self.md(name)?.variables.push(var);
            }
            (Some("ScalarVariable"), "Real" | "Integer" | "Boolean" | "String" | "Enumeration") => {
                let md = self.md(name)?;
                let var = md.variables.last_mut().ok_or_else(|| err_invalid("type element outside a variable"))?;
                apply_type_element(var, name, a)?;
            }
            (Some(list @ ("Outputs" | "Derivatives" | "InitialUnknowns")), "Unknown") => {
                let list = list.to_owned();
                let unknown = Unknown {
                    index: a.int(name, "index")?.ok_or_else(|| err_invalid("<Unknown> has no index attribute"))?,
                    dependencies: a
                        .get("dependencies")
                        .map(|d| {
                            d.split_whitespace()
                                .map(|x| x.parse().map_err(|_| err_invalid(format!("bad dependency index {x:?}"))))
                                .collect::<Result<Vec<usize>, _>>()
                        })
                        .transpose()?,
                };
                let ms = &mut self.md(name)?.model_structure;
                match list.as_str() {
                    "Outputs" => ms.outputs.push(unknown),
                    "Derivatives" => ms.derivatives.push(unknown),
                    _ => ms.initial_unknowns.push(unknown),
                }
            }
            _ => {}
        }
        Ok(())
    }
}

fn var_type(elem: &str) -> VarType {
    match elem {
        "Real" => VarType::Real,
        "Integer" => VarType::Integer,
        "Boolean" => VarType::Boolean,
        "String" => VarType::String,
        _ => VarType::Enumeration,
    }
}

fn interface_info(elem: &str, a: &Attrs) -> Result<InterfaceInfo, SchemaError> {
    Ok(InterfaceInfo {
        model_identifier: a.required(elem, "modelIdentifier")?,
        needs_execution_tool: a.bool(elem, "needsExecutionTool")?,
        can_be_instantiated_only_once_per_process: a.bool(elem, "canBeInstantiatedOnlyOncePerProcess")?,
        can_not_use_memory_management_functions: a.bool(elem, "canNotUseMemoryManagementFunctions")?,
        can_get_and_set_fmu_state: a.bool(elem, "canGetAndSetFMUstate")?,
        can_serialize_fmu_state: a.bool(elem, "canSerializeFMUstate")?,
        provides_directional_derivative: a.bool(elem, "providesDirectionalDerivative")?,
        completed_integrator_step_not_needed: a.bool(elem, "completedIntegratorStepNotNeeded")?,
        can_handle_variable_communication_step_size: a.bool(elem, "canHandleVariableCommunicationStepSize")?,
        can_interpolate_inputs: a.bool(elem, "canInterpolateInputs")?,
        max_output_derivative_order: a.int(elem, "maxOutputDerivativeOrder")?.unwrap_or(0),
        can_run_asynchronuously: a.bool(elem, "canRunAsynchronuously")?,
    })
}

fn scalar_variable(a: &Attrs) -> Result<ScalarVariable, SchemaError> {
    let name = a.required("ScalarVariable", "name")?;
    let value_reference = value_reference(a, &name)?;
    let causality = causality(a.get("causality").unwrap_or("local"), &name)?;
    let variability = variability(a.get("variability").unwrap_or("continuous"), &name)?;
    let initial = initial(a, &name)?;
    Ok(ScalarVariable::new(name, value_reference, a.string("description"), causality, variability, initial))
}

/// Names the variable in a reader's error.
fn in_variable(name: &str) -> impl Fn(SchemaError) -> SchemaError + '_ {
    move |e| match e {
        SchemaError::Invalid(msg) => err_invalid(format!("variable {name:?}: {msg}")),
        other => other,
    }
}

/// The `valueReference` of the variable `name` (every version).
fn value_reference(a: &Attrs, name: &str) -> Result<u32, SchemaError> {
    let text = a.get("valueReference").ok_or_else(|| err_invalid(format!("variable {name:?}: no valueReference")))?;
    text.trim()
        .parse::<u32>()
        .map_err(|_| err_invalid(format!("variable {name:?}: valueReference is not an unsigned integer")))
}

/// A `causality` of FMI 2.0 and 3.0.
fn causality(text: &str, name: &str) -> Result<Causality, SchemaError> {
    Ok(match text {
        "parameter" => Causality::Parameter,
        "calculatedParameter" => Causality::CalculatedParameter,
        "input" => Causality::Input,
        "output" => Causality::Output,
        "local" => Causality::Local,
        "independent" => Causality::Independent,
        other => return Err(err_invalid(format!("variable {name:?}: unknown causality {other:?}"))),
    })
}

/// A `variability` of FMI 2.0 and 3.0.
fn variability(text: &str, name: &str) -> Result<Variability, SchemaError> {
    Ok(match text {
        "constant" => Variability::Constant,
        "fixed" => Variability::Fixed,
        "tunable" => Variability::Tunable,
        "discrete" => Variability::Discrete,
        "continuous" => Variability::Continuous,
        other => return Err(err_invalid(format!("variable {name:?}: unknown variability {other:?}"))),
    })
}

/// The `initial` attribute of FMI 2.0 and 3.0, if written.
fn initial(a: &Attrs, name: &str) -> Result<Option<Initial>, SchemaError> {
    Ok(match a.get("initial") {
        None => None,
        Some("exact") => Some(Initial::Exact),
        Some("approx") => Some(Initial::Approx),
        Some("calculated") => Some(Initial::Calculated),
        Some(other) => return Err(err_invalid(format!("variable {name:?}: unknown initial {other:?}"))),
    })
}

/// A start value as written, typed by `var_type` (Binary in hex; `None` for a Clock).
fn parse_start(var_type: VarType, text: &str, name: &str) -> Result<Option<Value>, SchemaError> {
    let bad = |what: &str| err_invalid(format!("variable {name:?}: start {text:?} is not {what}"));
    Ok(Some(match var_type {
        VarType::Real => Value::Real(text.trim().parse().map_err(|_| bad("a number"))?),
        VarType::Integer | VarType::Enumeration => Value::Integer(text.trim().parse().map_err(|_| bad("an integer"))?),
        VarType::Boolean => Value::Boolean(match text.trim() {
            "true" | "1" => true,
            "false" | "0" => false,
            _ => return Err(bad("a boolean")),
        }),
        VarType::String => Value::String(text.to_owned()),
        VarType::Binary => Value::Binary(parse_hex(text).ok_or_else(|| bad("hex digits"))?),
        VarType::Clock => return Ok(None),
    }))
}

impl SimpleType {
    /// A type definition with its name and description; its type element fills in the rest.
    fn named(elem: &str, a: &Attrs) -> Result<Self, SchemaError> {
        Ok(SimpleType {
            name: a.required(elem, "name")?,
            description: a.string("description"),
            base_type: VarType::Real,
            quantity: None,
            unit: None,
            min: None,
            max: None,
            nominal: None,
            items: vec![],
        })
    }

    /// The attributes of its type element (`Real`, `RealType`, ...).
    fn apply(&mut self, base_type: VarType, elem: &str, a: &Attrs) -> Result<(), SchemaError> {
        self.base_type = base_type;
        self.quantity = a.string("quantity");
        self.unit = a.string("unit");
        self.min = a.f64(elem, "min")?;
        self.max = a.f64(elem, "max")?;
        self.nominal = a.f64(elem, "nominal")?;
        Ok(())
    }
}

impl ScalarVariable {
    /// A Real variable with these attributes and no type attributes yet (the type element sets
    /// them).
    fn new(
        name: String,
        value_reference: u32,
        description: Option<String>,
        causality: Causality,
        variability: Variability,
        initial: Option<Initial>,
    ) -> Self {
        ScalarVariable {
            name,
            value_reference,
            description,
            causality,
            variability,
            initial,
            var_type: VarType::Real,
            declared_type: None,
            start: None,
            min: None,
            max: None,
            nominal: None,
            unit: None,
            derivative: None,
            reinit: false,
            display_unit: None,
            alias_of: None,
            negated: false,
            fmi3: None,
        }
    }
}

fn apply_type_element(var: &mut ScalarVariable, elem: &str, a: &Attrs) -> Result<(), SchemaError> {
    let name = var.name.clone();
    let ctx = in_variable(&name);
    var.var_type = var_type(elem);
    var.declared_type = a.string("declaredType");
    var.unit = a.string("unit");
    var.display_unit = a.string("displayUnit");
    var.min = a.f64(elem, "min").map_err(&ctx)?;
    var.max = a.f64(elem, "max").map_err(&ctx)?;
    var.nominal = a.f64(elem, "nominal").map_err(&ctx)?;
    var.derivative = a.int(elem, "derivative").map_err(&ctx)?;
    var.reinit = a.bool(elem, "reinit").map_err(&ctx)?;
    var.start = a.get("start").map(|text| parse_start(var.var_type, text, &name)).transpose()?.flatten();
    Ok(())
}

/// The most event indicators a model may declare (each costs a slot per step).
const MAX_EVENT_INDICATORS: usize = 1_000_000;

/// Resolves declared types and checks cross references once the whole document is read.
fn finish(md: &mut ModelDescription) -> Result<(), SchemaError> {
    if md.model_exchange.is_none() && md.co_simulation.is_none() {
        return Err(err_invalid("neither <ModelExchange> nor <CoSimulation> is present"));
    }
    if md.number_of_event_indicators > MAX_EVENT_INDICATORS {
        return Err(err_invalid(format!(
            "{} event indicators, more than the {MAX_EVENT_INDICATORS} fmucal handles",
            md.number_of_event_indicators
        )));
    }
    let n = md.variables.len();
    for var in &mut md.variables {
        if let Some(tname) = &var.declared_type {
            let st = md
                .type_definitions
                .iter()
                .find(|t| &t.name == tname)
                .ok_or_else(|| err_invalid(format!("variable {:?}: unknown declaredType {tname:?}", var.name)))?;
            if st.base_type == var.var_type {
                var.unit = var.unit.take().or_else(|| st.unit.clone());
                var.min = var.min.or(st.min);
                var.max = var.max.or(st.max);
                var.nominal = var.nominal.or(st.nominal);
            } else {
                // The XML schema cannot express this rule and `fmpy validate` does not check
                // it, so such FMUs exist: keep the variable, without the type's attributes.
                tracing::warn!(
                    variable = %var.name,
                    "declaredType {tname:?} is a {:?}, not a {:?}; its attributes are ignored",
                    st.base_type,
                    var.var_type
                );
            }
        }
        if let Some(d) = var.derivative
            && (d == 0 || d > n)
        {
            return Err(err_invalid(format!("variable {:?}: derivative index {d} out of range 1..={n}", var.name)));
        }
        // fmucal sets every numeric input from the start on; a String or Binary input it never
        // sets may go without (FMPy loads such FMUs too).
        if matches!(var.causality, Causality::Input)
            && var.start.is_none()
            && !matches!(var.var_type, VarType::String | VarType::Binary | VarType::Clock)
        {
            return Err(err_invalid(format!("input {:?} has no start value", var.name)));
        }
    }
    // A variable with the type and value reference of an earlier one is its alias (FMI 2.0
    // writes aliases so; FMI 1.0 and 3.0 name the base explicitly, and their readers set it).
    // The base is the first that is an input, parameter or output, else the first.
    let mut base: HashMap<(VarType, u32), usize> = HashMap::new();
    let interface =
        |v: &ScalarVariable| matches!(v.causality, Causality::Input | Causality::Parameter | Causality::Output);
    for (k, v) in md.variables.iter().enumerate().filter(|(_, v)| v.alias_of.is_none()) {
        let b = base.entry((v.var_type, v.value_reference)).or_insert(k);
        if !interface(&md.variables[*b]) && interface(v) {
            *b = k;
        }
    }
    for k in 0..md.variables.len() {
        let b = base.get(&(md.variables[k].var_type, md.variables[k].value_reference)).copied();
        if let Some(b) = b.filter(|b| *b != k && md.variables[k].alias_of.is_none()) {
            md.variables[k].alias_of = Some(md.variables[b].name.clone());
        }
    }
    let ms = &md.model_structure;
    for (list, unknowns) in
        [("Outputs", &ms.outputs), ("Derivatives", &ms.derivatives), ("InitialUnknowns", &ms.initial_unknowns)]
    {
        for u in unknowns {
            if u.index == 0 || u.index > n {
                return Err(err_invalid(format!("ModelStructure/{list}: index {} out of range 1..={n}", u.index)));
            }
        }
    }
    // Only ModelStructure/Derivatives defines the continuous states (FMI 2.0.4 section 2.2.8).
    // Tools also put `derivative` on aliases and on variables that are not states; those are
    // valid, so the converse is not checked (neither does `fmpy validate`).
    for u in &ms.derivatives {
        if md.variables[u.index - 1].derivative.is_none() {
            return Err(err_invalid(format!(
                "ModelStructure/Derivatives: variable {:?} has no derivative attribute",
                md.variables[u.index - 1].name
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"<?xml version="1.0"?>
<fmiModelDescription fmiVersion="2.0" modelName="M" guid="{g}" generationTool="t">
  <ModelExchange modelIdentifier="M"/>
  <ModelVariables>
    <ScalarVariable name="x" valueReference="0" causality="output" variability="continuous" initial="exact"><Real start="2"/></ScalarVariable>
    <ScalarVariable name="der(x)" valueReference="1"><Real derivative="1"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="1"/></Outputs><Derivatives><Unknown index="2"/></Derivatives></ModelStructure>
</fmiModelDescription>"#;

    #[test]
    fn minimal_description_yields_state_derivative_pair() {
        let md = ModelDescription::parse(MINIMAL).unwrap();
        let states = md.states();
        assert_eq!(states.len(), 1);
        assert_eq!(states[0].0.name, "x");
        assert_eq!(states[0].1.name, "der(x)");
        assert_eq!(md.variable("x").unwrap().start, Some(Value::Real(2.0)));
        assert_eq!(md.variable("der(x)").unwrap().effective_initial(), Some(Initial::Calculated));
    }

    #[test]
    fn unknown_versions_are_rejected_as_unsupported() {
        for (v, want) in [("4.0", "4.0"), ("0.9", "0.0"), ("5.1-beta", "5.0")] {
            let xml = MINIMAL.replace("fmiVersion=\"2.0\"", &format!("fmiVersion=\"{v}\""));
            match ModelDescription::parse(&xml) {
                Err(SchemaError::UnsupportedVersion(got)) => assert_eq!(got, want),
                other => panic!("expected UnsupportedVersion for {v}, got {other:?}"),
            }
        }
    }

    #[test]
    fn truncated_xml_is_a_malformed_error() {
        let cut = &MINIMAL[..MINIMAL.len() / 2];
        assert!(
            matches!(ModelDescription::parse(cut), Err(SchemaError::Xml { .. })),
            "{:?}",
            ModelDescription::parse(cut)
        );
    }

    #[test]
    fn derivative_attributes_outside_model_structure_are_accepted() {
        // An alias of the state carrying `derivative` (as tools export it) is not a state.
        let xml = MINIMAL.replace(
            "</ModelVariables>",
            r#"<ScalarVariable name="der(x)Alias" valueReference="1"><Real derivative="1"/></ScalarVariable>
<ScalarVariable name="y" valueReference="2"><Real/></ScalarVariable>
<ScalarVariable name="w" valueReference="3"><Real derivative="4"/></ScalarVariable>
</ModelVariables>"#,
        );
        let md = ModelDescription::parse(&xml).unwrap();
        let states = md.states();
        assert_eq!(states.len(), 1);
        assert_eq!((states[0].0.name.as_str(), states[0].1.name.as_str()), ("x", "der(x)"));
        assert_eq!(md.variable("w").unwrap().derivative, Some(4));
    }

    #[test]
    fn a_derivatives_entry_without_derivative_attribute_is_invalid() {
        let xml = MINIMAL.replace("<Real derivative=\"1\"/>", "<Real/>");
        let err = ModelDescription::parse(&xml).unwrap_err().to_string();
        assert!(err.contains("has no derivative attribute"), "{err}");
    }

    #[test]
    fn declared_type_of_another_base_type_is_ignored_not_refused() {
        let xml = MINIMAL
            .replace(
                "<ModelVariables>",
                r#"<TypeDefinitions><SimpleType name="Count"><Integer min="0" max="9"/></SimpleType></TypeDefinitions><ModelVariables>"#,
            )
            .replace("<Real start=\"2\"/>", "<Real declaredType=\"Count\" start=\"2\"/>");
        let md = ModelDescription::parse(&xml).unwrap();
        let x = md.variable("x").unwrap();
        assert_eq!((x.min, x.max), (None, None));
    }

    #[test]
    fn derivative_index_out_of_range_is_invalid() {
        let xml = MINIMAL.replace("derivative=\"1\"", "derivative=\"7\"");
        let err = ModelDescription::parse(&xml).unwrap_err().to_string();
        assert!(err.contains("derivative index 7"), "{err}");
    }
}
