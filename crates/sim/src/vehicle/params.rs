//! The parameters the simulated autopilot answers for (the MAVLink parameter protocol:
//! PARAM_REQUEST_READ by name or index, PARAM_REQUEST_LIST, PARAM_SET, each answered with
//! PARAM_VALUE), and ArduPilot's "accept MAVLink only from the GCS" option.
//!
//! Not the autopilots' whole lists (about 1,240 ArduCopter 4.7 parameters): the ones a ground
//! station checks before a flight, with the names, types and values ArduCopter and ArduRover
//! 4.7.0-dev SITL answered a PARAM_REQUEST_LIST with (the `copter.parm` / `rover.parm` SITL
//! defaults applied) and PX4 1.16's defaults (its generated `parameters.json`), listed in
//! `fleetmap_core::preflight::names`. A value set ([`VehicleConfig::params`], `fleetmap sim
//! --param`, or PARAM_SET) is answered back; only the GCS-id option changes what the vehicle
//! does (the failsafes here follow [`VehicleConfig::failsafe`] and the PX4 data-link setting,
//! whatever their parameters say).
//!
//! Wire details followed: ArduPilot sends every value as a float of its number
//! (`libraries/GCS_MAVLink/GCS_Param.cpp`); PX4 sends integers byte-wise, the float's bits
//! being the integer's (`MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE`,
//! `src/modules/mavlink/mavlink_parameters.cpp`). An unknown name gets no answer. With
//! `MAV_OPTIONS` bit 0 set, ArduPilot drops every message whose sender is not a GCS id
//! (`MAV_GCS_SYSID`, up to `MAV_GCS_SYSID_HI`) except RADIO / RADIO_STATUS
//! (`GCS_MAVLINK::accept_packet`): it goes on streaming but obeys nobody else.

use super::*;
use fleetmap_core::proto::params::{param_id, param_name};
use mav::MavParamType as T;

/// One parameter: name, value, type.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Param {
    pub(crate) name: String,
    pub(crate) value: f32,
    pub(crate) ty: T,
}

fn p(name: &str, value: f32, ty: T) -> Param {
    Param {
        name: name.into(),
        value,
        ty,
    }
}

/// The defaults of a vehicle of `cfg`'s flavour, then `cfg.params` over them (an unknown
/// name is added as a float).
pub(crate) fn table(cfg: &VehicleConfig) -> Vec<Param> {
    let f = cfg.flavour;
    let copter = f.is_copter();
    let mut v = if f.is_ardupilot() {
        let mut v = vec![
            p("MAV_SYSID", f32::from(cfg.sysid), T::MAV_PARAM_TYPE_INT16),
            p("MAV_GCS_SYSID", 255.0, T::MAV_PARAM_TYPE_INT16),
            p("MAV_GCS_SYSID_HI", 0.0, T::MAV_PARAM_TYPE_INT16),
            p("MAV_OPTIONS", 0.0, T::MAV_PARAM_TYPE_INT16),
            p("FS_GCS_ENABLE", 0.0, T::MAV_PARAM_TYPE_INT8),
            p("FS_GCS_TIMEOUT", 5.0, T::MAV_PARAM_TYPE_REAL32),
            p("BATT_FS_LOW_ACT", 0.0, T::MAV_PARAM_TYPE_INT8),
            p("BATT_FS_CRT_ACT", 0.0, T::MAV_PARAM_TYPE_INT8),
            p("BATT_LOW_VOLT", 10.5, T::MAV_PARAM_TYPE_REAL32),
            p("FENCE_ENABLE", 0.0, T::MAV_PARAM_TYPE_INT8),
            p("FENCE_ACTION", 1.0, T::MAV_PARAM_TYPE_INT8),
            p("FENCE_TYPE", 7.0, T::MAV_PARAM_TYPE_INT8),
        ];
        // SERIAL0's stream rates: ArduCopter SITL 0 (nothing until asked), ArduRover 1 Hz
        // and parameters at 10 Hz
        let rate = if copter { 0.0 } else { 1.0 };
        for s in [
            "RAW_SENS", "EXT_STAT", "RC_CHAN", "RAW_CTRL", "POSITION", "EXTRA1", "EXTRA2", "EXTRA3",
        ] {
            v.push(p(&format!("MAV1_{s}"), rate, T::MAV_PARAM_TYPE_INT16));
        }
        v.push(p(
            "MAV1_PARAMS",
            if copter { 0.0 } else { 10.0 },
            T::MAV_PARAM_TYPE_INT16,
        ));
        if copter {
            v.push(p("RTL_ALT", 1500.0, T::MAV_PARAM_TYPE_INT32));
        } else {
            v.push(p("FS_ACTION", 2.0, T::MAV_PARAM_TYPE_INT8));
        }
        v
    } else {
        let dll = if cfg.px4_datalink_required { 2.0 } else { 0.0 };
        let mut v = vec![
            p("MAV_SYS_ID", f32::from(cfg.sysid), T::MAV_PARAM_TYPE_INT32),
            p("MAV_COMP_ID", 1.0, T::MAV_PARAM_TYPE_INT32),
            p("NAV_DLL_ACT", dll, T::MAV_PARAM_TYPE_INT32),
            p("COM_DL_LOSS_T", 10.0, T::MAV_PARAM_TYPE_INT32),
            p("COM_LOW_BAT_ACT", 0.0, T::MAV_PARAM_TYPE_INT32),
            p("BAT_CRIT_THR", 0.07, T::MAV_PARAM_TYPE_REAL32),
            p("BAT_EMERGEN_THR", 0.05, T::MAV_PARAM_TYPE_REAL32),
            p("GF_ACTION", 2.0, T::MAV_PARAM_TYPE_INT32),
        ];
        if copter {
            v.push(p("RTL_RETURN_ALT", 60.0, T::MAV_PARAM_TYPE_REAL32));
        }
        v
    };
    for (name, value) in &cfg.params {
        match v.iter_mut().find(|q| q.name == *name) {
            Some(q) => q.value = *value,
            None => v.push(p(name, *value, T::MAV_PARAM_TYPE_REAL32)),
        }
    }
    v
}

/// Whether `ty` is one of the integer types.
fn is_integer(ty: T) -> bool {
    !matches!(ty, T::MAV_PARAM_TYPE_REAL32 | T::MAV_PARAM_TYPE_REAL64)
}

impl SimVehicle {
    /// The value of parameter `name`, if the vehicle has it.
    pub fn param(&self, name: &str) -> Option<f32> {
        self.params.iter().find(|q| q.name == name).map(|q| q.value)
    }

    fn param_is(&self, name: &str, bit_or_value: impl Fn(i64) -> bool) -> bool {
        self.param(name)
            .is_some_and(|v| bit_or_value(v.round() as i64))
    }

    /// ArduPilot with `MAV_OPTIONS` bit 0: whether a message from system `sysid` is dropped.
    pub(super) fn refuses_sender(&self, sysid: u8, msg: &MavMessage) -> bool {
        if !self.cfg.flavour.is_ardupilot() || !self.param_is("MAV_OPTIONS", |o| o & 1 == 1) {
            return false;
        }
        if matches!(msg, MavMessage::RADIO_STATUS(_)) {
            return false;
        }
        let gcs = self
            .param("MAV_GCS_SYSID")
            .map_or(255, |g| g.round() as i64);
        let hi = self
            .param("MAV_GCS_SYSID_HI")
            .map_or(0, |h| h.round() as i64);
        let s = i64::from(sysid);
        !(s == gcs || (hi >= gcs && (gcs..=hi).contains(&s)))
    }

    /// PARAM_VALUE for the parameter at `index`.
    fn param_value(&self, index: usize) -> Option<MavMessage> {
        let q = self.params.get(index)?;
        let value = if !self.cfg.flavour.is_ardupilot() && is_integer(q.ty) {
            f32::from_bits(q.value.round() as i32 as u32)
        } else {
            q.value
        };
        Some(MavMessage::PARAM_VALUE(mav::PARAM_VALUE_DATA {
            param_value: value,
            param_count: self.params.len() as u16,
            param_index: index as u16,
            param_id: param_id(&q.name),
            param_type: q.ty,
        }))
    }

    fn index_of(&self, name: &str) -> Option<usize> {
        self.params.iter().position(|q| q.name == name)
    }

    /// Answer a parameter-protocol message; false when `msg` is not one for this vehicle.
    pub(super) fn handle_param_message(&mut self, msg: &MavMessage) -> bool {
        let me = self.cfg.sysid;
        let answers: Vec<MavMessage> = match msg {
            MavMessage::PARAM_REQUEST_READ(r) if r.target_system == me => {
                let index = if r.param_index >= 0 {
                    Some(r.param_index as usize)
                } else {
                    self.index_of(&param_name(&r.param_id))
                };
                index
                    .and_then(|i| self.param_value(i))
                    .into_iter()
                    .collect()
            }
            MavMessage::PARAM_REQUEST_LIST(r) if r.target_system == me => (0..self.params.len())
                .filter_map(|i| self.param_value(i))
                .collect(),
            MavMessage::PARAM_SET(s) if s.target_system == me => {
                let name = param_name(&s.param_id);
                match self.index_of(&name) {
                    Some(i) => {
                        let q = &mut self.params[i];
                        q.value = if !self.cfg.flavour.is_ardupilot() && is_integer(q.ty) {
                            s.param_value.to_bits() as i32 as f32
                        } else {
                            s.param_value
                        };
                        self.param_value(i).into_iter().collect()
                    }
                    None => Vec::new(),
                }
            }
            _ => return false,
        };
        for a in answers {
            self.queue(AUTOPILOT_COMPID, a);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flavour::SimFlavour;

    fn vehicle(flavour: SimFlavour, params: &[(&str, f32)]) -> SimVehicle {
        let mut cfg = VehicleConfig::new(3, flavour, (-35.36, 149.16));
        cfg.params = params.iter().map(|(n, v)| ((*n).into(), *v)).collect();
        SimVehicle::new(cfg, None, Time::from_secs(0))
    }

    fn read(v: &mut SimVehicle, from: u8, name: &str) -> Option<(f32, T)> {
        let h = header(Endpoint::new(from, fleetmap_core::proto::GCS_COMPID), 0);
        let req = MavMessage::PARAM_REQUEST_READ(mav::PARAM_REQUEST_READ_DATA {
            param_index: -1,
            target_system: 3,
            target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
            param_id: param_id(name),
        });
        v.handle_message(&h, &req, Time::from_secs(1));
        let mut got = None;
        while let Some((_, m)) = v.poll_transmit() {
            if let MavMessage::PARAM_VALUE(p) = m {
                assert_eq!(param_name(&p.param_id), name);
                got = Some((p.param_value, p.param_type));
            }
        }
        got
    }

    #[test]
    fn answers_by_name_with_the_defaults_and_the_set_values() {
        let mut ap = vehicle(SimFlavour::ARDU_COPTER, &[("FS_GCS_ENABLE", 1.0)]);
        assert_eq!(
            read(&mut ap, fleetmap_core::proto::GCS_SYSID, "RTL_ALT"),
            Some((1500.0, T::MAV_PARAM_TYPE_INT32))
        );
        assert_eq!(
            read(&mut ap, fleetmap_core::proto::GCS_SYSID, "FS_GCS_ENABLE").map(|x| x.0),
            Some(1.0)
        );
        assert_eq!(
            read(&mut ap, fleetmap_core::proto::GCS_SYSID, "NO_SUCH_PARAM"),
            None
        );
        // PX4 sends integers byte-wise
        let mut px4 = vehicle(SimFlavour::PX4_COPTER, &[]);
        let (raw, ty) =
            read(&mut px4, fleetmap_core::proto::GCS_SYSID, "GF_ACTION").expect("GF_ACTION");
        assert_eq!(ty, T::MAV_PARAM_TYPE_INT32);
        assert_eq!(raw.to_bits(), 2);
        assert_eq!(
            read(&mut px4, fleetmap_core::proto::GCS_SYSID, "RTL_RETURN_ALT").map(|x| x.0),
            Some(60.0)
        );
    }

    #[test]
    fn an_enforced_gcs_id_makes_ardupilot_deaf_to_everyone_else() {
        let mut ap = vehicle(
            SimFlavour::ARDU_COPTER,
            &[("MAV_GCS_SYSID", 250.0), ("MAV_OPTIONS", 1.0)],
        );
        assert_eq!(
            read(&mut ap, fleetmap_core::proto::GCS_SYSID, "MAV_OPTIONS"),
            None
        );
        assert_eq!(read(&mut ap, 250, "MAV_OPTIONS").map(|x| x.0), Some(1.0));
    }
}
