//! Geofences built from the fence list (MAV_MISSION_TYPE_FENCE items): inclusion and
//! exclusion polygons (MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION / _EXCLUSION, param1 =
//! vertex count, consecutive items) and circles (MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION /
//! _EXCLUSION, param1 = radius), as ArduPilot's AC_PolyFence_loader and PX4's geofence read
//! them. A point breaches the fence when it is inside an exclusion zone, or when inclusion
//! zones exist and it is inside none of them.

use fleetmap_core::geo::local;
use fleetmap_core::mission::item::MissionItem;
use fleetmap_core::world::point_in_polygon;
use mavlink::dialects::ardupilotmega::MavCmd;
use num_traits::FromPrimitive;

#[derive(Clone, Debug, PartialEq)]
enum Zone {
    Polygon {
        inclusion: bool,
        pts: Vec<(f64, f64)>,
    },
    Circle {
        inclusion: bool,
        c: (f64, f64),
        r: f64,
    },
}

/// A fence in local metres (east, north) around a reference point.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fence {
    zones: Vec<Zone>,
}

impl Fence {
    /// Build a fence from fence items; malformed polygons (a vertex count that does not
    /// match the run of items) are skipped, as the autopilots reject them.
    pub fn from_items(items: &[MissionItem], reference: (f64, f64)) -> Fence {
        let to_local = |it: &MissionItem| {
            let (n, e) = local::delta(reference.0, reference.1, it.lat(), it.lon());
            (e, n)
        };
        let mut zones = Vec::new();
        let mut i = 0;
        while i < items.len() {
            let it = &items[i];
            match MavCmd::from_u16(it.command) {
                Some(
                    MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
                    | MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
                ) => {
                    let n = it.param1.max(0.0).round() as usize;
                    let run = items[i..]
                        .iter()
                        .take_while(|x| x.command == it.command && x.param1 == it.param1)
                        .count();
                    if n >= 3 && run >= n {
                        zones.push(Zone::Polygon {
                            inclusion: it.command
                                == MavCmd::MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION as u16,
                            pts: items[i..i + n].iter().map(to_local).collect(),
                        });
                        i += n;
                    } else {
                        i += run.max(1);
                    }
                }
                Some(
                    MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION
                    | MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION,
                ) => {
                    zones.push(Zone::Circle {
                        inclusion: it.command == MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION as u16,
                        c: to_local(it),
                        r: f64::from(it.param1.max(0.0)),
                    });
                    i += 1;
                }
                _ => i += 1,
            }
        }
        Fence { zones }
    }

    /// Whether the fence has any zone.
    pub fn is_empty(&self) -> bool {
        self.zones.is_empty()
    }

    /// Whether local point (e, n) breaches the fence.
    pub fn breached(&self, e: f64, n: f64) -> bool {
        let mut has_inclusion = false;
        let mut in_inclusion = false;
        for z in &self.zones {
            let (inclusion, inside) = match z {
                Zone::Polygon { inclusion, pts } => (*inclusion, point_in_polygon(pts, e, n)),
                Zone::Circle { inclusion, c, r } => (*inclusion, (e - c.0).hypot(n - c.1) <= *r),
            };
            if inclusion {
                has_inclusion = true;
                in_inclusion |= inside;
            } else if inside {
                return true;
            }
        }
        has_inclusion && !in_inclusion
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vertex(cmd: u16, n: f32, lat: f64, lon: f64) -> MissionItem {
        MissionItem {
            param1: n,
            ..MissionItem::at(cmd, lat, lon, 0.0)
        }
    }

    #[test]
    fn exclusion_and_inclusion() {
        let r = (37.0, -80.0);
        let p = |n: f64, e: f64| local::offset(r.0, r.1, n, e);
        let mut items = Vec::new();
        for (n, e) in [(10.0, 10.0), (10.0, 20.0), (20.0, 20.0), (20.0, 10.0)] {
            let (a, b) = p(n, e);
            items.push(vertex(5002, 4.0, a, b));
        }
        let f = Fence::from_items(&items, r);
        assert!(f.breached(15.0, 15.0));
        assert!(!f.breached(0.0, 0.0));
        let (a, b) = p(0.0, 0.0);
        items.push(MissionItem {
            param1: 50.0,
            ..MissionItem::at(5003, a, b, 0.0)
        });
        let f = Fence::from_items(&items, r);
        assert!(!f.breached(30.0, 0.0));
        assert!(f.breached(60.0, 0.0));
        assert!(f.breached(15.0, 15.0));
        // a polygon with a wrong vertex count is ignored
        let bad = vec![vertex(5002, 5.0, a, b), vertex(5002, 5.0, a, b)];
        assert!(Fence::from_items(&bad, r).is_empty());
    }
}
