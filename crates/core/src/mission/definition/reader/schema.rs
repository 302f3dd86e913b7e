//! Step 2 of loading a mission file: the walk of the spanned TOML tree against the
//! schema, table by table (`[grid]`, `[flight]`, `[camera]`, `[battery]`, `[[vehicles]]`,
//! `[area]`, then each kind's table, read by the kind's module), through the typed readers
//! of [`Ctx`].

use super::*;

/// The keys of the file's root: the common parts, each kind's table (in the kinds' order)
/// between `area` and `link`.
fn root_keys() -> Vec<&'static str> {
    let common = [
        "name",
        "kind",
        "description",
        "grid",
        "flight",
        "camera",
        "battery",
        "vehicles",
        "area",
    ];
    let tables = MissionKind::ALL.iter().map(|k| k.table());
    common.into_iter().chain(tables).chain(["link"]).collect()
}

/// Parse `text` (steps 1 and 2). Syntax errors end the reading; structural errors are kept
/// in the returned context (with placeholders in the definition) so that validation can add
/// its own.
pub(in crate::mission::definition) fn read<'t>(
    text: &'t str,
    file: &str,
) -> Result<(MissionDef, Ctx<'t>), DefErrors> {
    let mut ctx = Ctx::new(file, text);
    let (doc, syntax) = DeTable::parse_recoverable(text);
    if !syntax.is_empty() {
        let mut errs: Vec<(usize, String)> = syntax
            .iter()
            .map(|e| (e.span().map_or(0, |s| s.start), e.message().to_string()))
            .collect();
        errs.sort_by_key(|(o, _)| *o);
        let mut last_line = 0;
        for (offset, msg) in errs {
            let (line, _) = line_col(text, offset);
            if line == last_line || ctx.errors.len() >= MAX_SYNTAX_ERRORS {
                continue;
            }
            last_line = line;
            ctx.push(offset, "", format!("TOML syntax: {msg}"));
        }
        return Err(ctx
            .finish()
            .err()
            .unwrap_or(DefErrors { errors: Vec::new() }));
    }
    let root_val = Spanned::new(0..0, DeValue::Table(doc.into_inner()));
    let root = ctx.table("", &root_val, &root_keys());
    let empty = DeTable::default();
    let root = root.unwrap_or(&empty);
    let def = read_root(&mut ctx, root);
    Ok((def, ctx))
}

fn read_root(ctx: &mut Ctx<'_>, root: &DeTable<'_>) -> MissionDef {
    let name = ctx
        .req(root, "", "name", "a string", |c, p, v| {
            c.str_of(p, v, "a string")
        })
        .unwrap_or_default();
    let kinds: Vec<_> = MissionKind::ALL.iter().map(|&k| (k.as_str(), k)).collect();
    let kind = ctx
        .req(
            root,
            "",
            "kind",
            &MissionKind::names(MissionKind::ALL.iter().copied(), true),
            |c, p, v| c.word_of(p, v, &kinds),
        )
        .unwrap_or(MissionKind::ALL[0]);
    let description = ctx
        .opt(root, "", "description", |c, p, v| {
            c.str_of(p, v, "a string")
        })
        .unwrap_or(None);

    let grid = read_grid(ctx, root);
    let flight = read_flight(ctx, root);
    let camera = read_camera(ctx, root);
    let battery = read_battery(ctx, root);
    let vehicles = read_vehicles(ctx, root);
    let area = read_area(ctx, root);
    let mut def = MissionDef::without_sections(
        name,
        kind,
        description,
        grid,
        flight,
        camera,
        battery,
        vehicles,
        area,
    );
    // Every kind's table, whatever the file's kind, read by the kind's module.
    for k in MissionKind::ALL {
        k.section().read(ctx, root, &mut def);
    }
    def.link = ctx.opt(root, "", "link", Ctx::link_of).unwrap_or(None);
    def
}

/// A required table: reported missing (and poisoned) when absent.
fn required_table<'a, 'i>(
    ctx: &mut Ctx<'_>,
    root: &'a DeTable<'i>,
    key: &str,
    known: &[&str],
) -> Option<&'a DeTable<'i>> {
    match get(root, key) {
        Some(v) => ctx.table(key, v, known),
        None => {
            ctx.missing("", key, &format!("a table [{key}]"));
            None
        }
    }
}

fn read_grid(ctx: &mut Ctx<'_>, root: &DeTable<'_>) -> GridDef {
    let mut grid = GridDef {
        origin: Origin::Vehicle,
        cell_size_m: f64::NAN,
    };
    let Some(t) = required_table(ctx, root, "grid", &["origin", "cell_size_m"]) else {
        return grid;
    };
    let origin_expected = "\"vehicle\" or { lat = …, lon = … }";
    if let Some(o) = ctx.req(t, "grid", "origin", origin_expected, |c, p, v| {
        match v.get_ref() {
            DeValue::String(s) if s.as_ref() == "vehicle" => {
                c.record(p, v);
                Some(Origin::Vehicle)
            }
            DeValue::Table(_) => c.latlon_of(p, v).map(Origin::Coordinates),
            _ => {
                c.record(p, v);
                c.wrong(p, v, origin_expected);
                None
            }
        }
    }) {
        grid.origin = o;
    }
    grid.cell_size_m = ctx
        .req(
            t,
            "grid",
            "cell_size_m",
            "a number > 0 (metres)",
            Ctx::num_of,
        )
        .unwrap_or(f64::NAN);
    grid
}

fn read_flight(ctx: &mut Ctx<'_>, root: &DeTable<'_>) -> FlightDef {
    let known = ["altitude_m", "altitude_separation_m", "speed_m_s"];
    let Some(t) = required_table(ctx, root, "flight", &known) else {
        return FlightDef {
            altitude_m: f64::NAN,
            altitude_separation_m: 0.0,
            speed_m_s: f64::NAN,
        };
    };
    FlightDef {
        altitude_m: ctx
            .req(
                t,
                "flight",
                "altitude_m",
                "a number > 0 (metres above home)",
                Ctx::num_of,
            )
            .unwrap_or(f64::NAN),
        altitude_separation_m: ctx.or(t, "flight", "altitude_separation_m", 0.0, Ctx::num_of),
        speed_m_s: ctx
            .req(t, "flight", "speed_m_s", "a number > 0 (m/s)", Ctx::num_of)
            .unwrap_or(f64::NAN),
    }
}

fn read_camera(ctx: &mut Ctx<'_>, root: &DeTable<'_>) -> CameraModel {
    let d = CameraModel::paper();
    let Some(t) = ctx.sub_table(root, "", "camera", &["hfov_deg", "width_px", "height_px"]) else {
        return d;
    };
    let px = |c: &mut Ctx<'_>, p: &str, v: &Val<'_>| {
        c.int_of::<u32>(p, v, "an integer number of pixels ≥ 1")
    };
    CameraModel {
        hfov_deg: ctx.or(t, "camera", "hfov_deg", d.hfov_deg, Ctx::num_of),
        width_px: ctx.or(t, "camera", "width_px", d.width_px, px),
        height_px: ctx.or(t, "camera", "height_px", d.height_px, px),
    }
}

fn read_battery(ctx: &mut Ctx<'_>, root: &DeTable<'_>) -> BatteryDef {
    let d = BatteryDef::default();
    let known = [
        "flight_time_min",
        "rtl_reserve_pct",
        "descent_rate_m_s",
        "landing_margin_s",
        "fresh_pct",
        "fresh_after_reboot_pct",
    ];
    let Some(t) = ctx.sub_table(root, "", "battery", &known) else {
        return d;
    };
    let p = "battery";
    BatteryDef {
        descent_rate_m_s: ctx.or(t, p, "descent_rate_m_s", d.descent_rate_m_s, Ctx::num_of),
        landing_margin_s: ctx.or(t, p, "landing_margin_s", d.landing_margin_s, Ctx::num_of),
        fresh_pct: ctx.or(t, p, "fresh_pct", d.fresh_pct, Ctx::num_of),
        fresh_after_reboot_pct: ctx.or(
            t,
            p,
            "fresh_after_reboot_pct",
            d.fresh_after_reboot_pct,
            Ctx::num_of,
        ),
        flight_time_min: ctx.or(
            t,
            "battery",
            "flight_time_min",
            d.flight_time_min,
            Ctx::num_of,
        ),
        rtl_reserve_pct: ctx.or(
            t,
            "battery",
            "rtl_reserve_pct",
            d.rtl_reserve_pct,
            Ctx::num_of,
        ),
    }
}

fn read_vehicles(ctx: &mut Ctx<'_>, root: &DeTable<'_>) -> Vec<VehicleDef> {
    let Some(v) = get(root, "vehicles") else {
        ctx.missing("", "vehicles", "[[vehicles]] tables");
        return Vec::new();
    };
    ctx.record("vehicles", v);
    let DeValue::Array(items) = v.get_ref() else {
        ctx.wrong("vehicles", v, "[[vehicles]] tables");
        return Vec::new();
    };
    let roles = [("drone", Role::Drone), ("station", Role::Station)];
    let mut out = Vec::with_capacity(items.len());
    for (i, item) in items.iter().enumerate() {
        let path = format!("vehicles[{i}]");
        let Some(t) = ctx.table(&path, item, &["sysid", "role", "name", "start", "link"]) else {
            ctx.poison("vehicles");
            continue;
        };
        let sysid = ctx
            .req(t, &path, "sysid", "an integer 1–254", |c, p, v| {
                c.int_of::<u8>(p, v, "an integer 1–254")
            })
            .unwrap_or(0);
        let role = ctx
            .req(t, &path, "role", "\"drone\" or \"station\"", |c, p, v| {
                c.word_of(p, v, &roles)
            })
            .unwrap_or(Role::Drone);
        let name = ctx
            .opt(t, &path, "name", |c, p, v| c.str_of(p, v, "a string"))
            .unwrap_or(None);
        let start = ctx.opt(t, &path, "start", Ctx::cell_of).unwrap_or(None);
        let link = ctx.opt(t, &path, "link", Ctx::link_of).unwrap_or(None);
        out.push(VehicleDef {
            sysid,
            role,
            name,
            start,
            link,
        });
    }
    out
}

fn read_area(ctx: &mut Ctx<'_>, root: &DeTable<'_>) -> AreaDef {
    let known = ["rows", "cols", "obstacles", "roads", "roads_are_candidates"];
    let mut area = AreaDef::default();
    let Some(t) = ctx.sub_table(root, "", "area", &known) else {
        return area;
    };
    let count = |c: &mut Ctx<'_>, p: &str, v: &Val<'_>| c.int_of::<u32>(p, v, "an integer ≥ 1");
    area.rows = ctx.opt(t, "area", "rows", count).unwrap_or(None);
    area.cols = ctx.opt(t, "area", "cols", count).unwrap_or(None);
    area.obstacles = ctx.or(t, "area", "obstacles", Vec::new(), Ctx::cells_of);
    area.roads = ctx.opt(t, "area", "roads", Ctx::cells_of).unwrap_or(None);
    area.roads_are_candidates = ctx.or(t, "area", "roads_are_candidates", true, Ctx::bool_of);
    area
}
