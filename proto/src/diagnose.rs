//! Conversions of the `Diagnose` RPC's settings: [`pb::DiagnoseSettings`] to and from the job
//! file's `[diagnose]` section ([`DiagnoseSpec`]). Unset fields take the section's defaults;
//! the result is validated as the section is. Errors name fields as the job file does
//! (`diagnose.ports[0].domain`), whichever way the settings came.

use fmucal_diagnose::spec::{DiagnoseSpec, PortDomain, PortSpec};
use fmucal_shared::job::JobError;

use crate::convert::ConvertError;
use crate::v1 as pb;

fn domain(k: usize, text: &str) -> Result<PortDomain, ConvertError> {
    match text {
        "mechanical" => Ok(PortDomain::Mechanical),
        "thermal" => Ok(PortDomain::Thermal),
        other => Err(ConvertError::InvalidAt {
            field: format!("diagnose.ports[{k}].domain"),
            message: format!("{other:?} is not \"mechanical\" or \"thermal\""),
        }),
    }
}

fn domain_name(d: PortDomain) -> &'static str {
    match d {
        PortDomain::Mechanical => "mechanical",
        PortDomain::Thermal => "thermal",
    }
}

impl TryFrom<pb::DiagnoseSettings> for DiagnoseSpec {
    type Error = ConvertError;

    fn try_from(p: pb::DiagnoseSettings) -> Result<Self, ConvertError> {
        let defaults = DiagnoseSpec::default();
        let ports = p
            .ports
            .into_iter()
            .enumerate()
            .map(|(k, q)| {
                Ok(PortSpec {
                    domain: domain(k, &q.domain)?,
                    port: q.port,
                    velocities: q.velocities,
                    positions: q.positions,
                    temperatures: q.temperatures,
                    scale: q.scale,
                    ambient: q.ambient,
                })
            })
            .collect::<Result<Vec<_>, ConvertError>>()?;
        let spec = DiagnoseSpec {
            ports,
            signals: p.signals,
            top: p.top.map_or(defaults.top, |v| v as usize),
            fix_base: p.fix_base.unwrap_or(defaults.fix_base),
            holdout: p.holdout,
            min_validation_gain: p.min_validation_gain.unwrap_or(defaults.min_validation_gain),
            confidence: p.confidence.unwrap_or(defaults.confidence),
            windows: p.windows.map_or(defaults.windows, |v| v as usize),
            rounds: p.rounds.map_or(defaults.rounds, |v| v as usize),
            series: p.series.unwrap_or(defaults.series),
            states: (p.states_given.unwrap_or(false) || !p.states.is_empty()).then_some(p.states),
            exclude: p.exclude,
        };
        spec.validate().map_err(|e| match e {
            JobError::Invalid { field, message } => ConvertError::InvalidAt { field, message },
            other => ConvertError::InvalidAt { field: "diagnose".into(), message: other.to_string() },
        })?;
        Ok(spec)
    }
}

/// The protobuf form of a `[diagnose]` section, for clients.
pub fn diagnose_to_proto(s: &DiagnoseSpec) -> pb::DiagnoseSettings {
    pb::DiagnoseSettings {
        ports: s
            .ports
            .iter()
            .map(|p| pb::DiagnosePort {
                port: p.port.clone(),
                domain: domain_name(p.domain).to_owned(),
                velocities: p.velocities.clone(),
                positions: p.positions.clone(),
                temperatures: p.temperatures.clone(),
                scale: p.scale,
                ambient: p.ambient,
            })
            .collect(),
        signals: s.signals.clone(),
        top: Some(u32::try_from(s.top).unwrap_or(u32::MAX)),
        fix_base: Some(s.fix_base),
        holdout: s.holdout,
        min_validation_gain: Some(s.min_validation_gain),
        confidence: Some(s.confidence),
        windows: Some(u32::try_from(s.windows).unwrap_or(u32::MAX)),
        rounds: Some(u32::try_from(s.rounds).unwrap_or(u32::MAX)),
        series: Some(s.series),
        states: s.states.clone().unwrap_or_default(),
        states_given: Some(s.states.is_some()),
        exclude: s.exclude.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn section(text: &str) -> DiagnoseSpec {
        let s: DiagnoseSpec = toml::from_str(text).unwrap();
        s.validate().unwrap();
        s
    }

    #[test]
    fn a_section_survives_the_protocol_unchanged() {
        for text in [
            "",
            "states = []",
            "states = [\"mass.v\", \"T\"]\nexclude = [\"F\"]",
            "top = 3\nfix_base = true\nholdout = 0.3\nmin_validation_gain = 0.05\nconfidence = 0.99\nwindows = 4\nrounds = 2\nseries = false\nsignals = [\"a.b\"]\n[[ports]]\nport = \"p\"\ndomain = \"mechanical\"\nvelocities = [\"v\"]\npositions = [\"x\"]\nscale = 0.5\n[[ports]]\nport = \"q\"\ndomain = \"thermal\"\ntemperatures = [\"T\"]\nambient = 300.0",
        ] {
            let s = section(text);
            assert_eq!(DiagnoseSpec::try_from(diagnose_to_proto(&s)).unwrap(), s, "{text}");
        }
    }

    #[test]
    fn unset_fields_take_the_sections_defaults() {
        let s = DiagnoseSpec::try_from(pb::DiagnoseSettings::default()).unwrap();
        assert_eq!(s, DiagnoseSpec::default());
    }

    #[test]
    fn bad_settings_name_the_field() {
        let port = |domain: &str| pb::DiagnosePort {
            port: "p".into(),
            domain: domain.into(),
            velocities: vec!["v".into()],
            ..Default::default()
        };
        let e = DiagnoseSpec::try_from(pb::DiagnoseSettings { ports: vec![port("electrical")], ..Default::default() })
            .unwrap_err();
        assert_eq!(e.to_string(), "diagnose.ports[0].domain: \"electrical\" is not \"mechanical\" or \"thermal\"");
        let e = DiagnoseSpec::try_from(pb::DiagnoseSettings { top: Some(0), ..Default::default() }).unwrap_err();
        assert_eq!(e.to_string(), "diagnose.top: must be at least 1");
        let e = DiagnoseSpec::try_from(pb::DiagnoseSettings {
            ports: vec![port("mechanical"), port("mechanical")],
            ..Default::default()
        })
        .unwrap_err();
        assert!(e.to_string().starts_with("diagnose.ports[1].port: \"p\" is listed twice"), "{e}");
    }
}
