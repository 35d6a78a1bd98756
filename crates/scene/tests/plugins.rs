//! The plugins Penumbra builds: each kind's table (`supported_plugins`)
//! drives both dispatch and the list in the "not supported" error, and the
//! README's table of Mitsuba plugins says the same.

use penumbra_scene::builder::{build, Overrides};
use penumbra_scene::desc::Kind;
use penumbra_scene::mitsuba::parse_str;
use penumbra_scene::supported_plugins;
use std::collections::BTreeSet;
use std::path::Path;

/// Every kind that has plugins, with a scene placing a plugin `{}` of it.
const KINDS: &[(Kind, &str)] = &[
    (Kind::Shape, r#"<shape type="{}"/>"#),
    (Kind::Bsdf, r#"<bsdf type="{}"/>"#),
    (Kind::Texture, r#"<texture type="{}"/>"#),
    (Kind::Emitter, r#"<emitter type="{}"/>"#),
    (Kind::Integrator, r#"<integrator type="{}"/>"#),
    (Kind::Sensor, r#"<sensor type="{}"><film type="hdrfilm"/></sensor>"#),
    (Kind::Film, r#"<sensor type="perspective"><film type="{}"/></sensor>"#),
    (Kind::Rfilter, r#"<sensor type="perspective"><film type="hdrfilm"><rfilter type="{}"/></film></sensor>"#),
    (Kind::Sampler, r#"<sensor type="perspective"><film type="hdrfilm"/><sampler type="{}"/></sensor>"#),
    (Kind::Medium, r#"<medium type="{}" id="m"/>"#),
    (Kind::Phase, r#"<medium type="homogeneous" id="m"><phase type="{}"/></medium>"#),
    (Kind::Volume, r#"<medium type="heterogeneous" id="m"><volume type="{}" name="sigma_t"/></medium>"#),
];

const SENSOR: &str = r#"<sensor type="perspective"><film type="hdrfilm"/></sensor>"#;

/// Builds a scene holding `object` (and a sensor, unless `object` is one);
/// the error message, if building fails.
fn build_error(kind: Kind, object: &str) -> Option<String> {
    let sensor = if matches!(kind, Kind::Sensor | Kind::Film | Kind::Rfilter | Kind::Sampler) { "" } else { SENSOR };
    let xml = format!("<scene version=\"3.0.0\">\n{sensor}\n{object}\n</scene>");
    let desc = match parse_str(&xml, Path::new("plugins.xml"), &[]) {
        Ok(desc) => desc,
        Err(e) => return Some(e.to_string()),
    };
    build(&desc, &Overrides::default()).err().map(|e| e.to_string())
}

#[test]
fn every_listed_plugin_is_built_and_any_other_is_refused_with_the_list() {
    for &(kind, template) in KINDS {
        let listed = supported_plugins(kind);
        assert!(!listed.is_empty(), "{}: no plugins", kind.tag());
        for entry in &listed {
            // An entry may carry a note after its name: "area (inside a shape)".
            let name = entry.split(' ').next().unwrap();
            // Missing parameters may fail the build, but never as an unknown plugin.
            if let Some(e) = build_error(kind, &template.replace("{}", name)) {
                assert!(!e.contains("not supported"), "{} '{name}' is listed but not built: {e}", kind.tag());
            }
        }
        let e = build_error(kind, &template.replace("{}", "nosuchplugin")).expect("an unknown plugin must fail");
        let tag = kind.tag();
        let expected = if kind == Kind::Texture {
            let quoted: Vec<String> = listed.iter().map(|t| format!("'{t}'")).collect();
            format!("texture type 'nosuchplugin' is not supported; Penumbra supports {}", quoted.join(" and "))
        } else {
            format!(
                "{tag} plugin 'nosuchplugin' is not supported by Penumbra; supported {tag} plugins: {}",
                listed.join(", ")
            )
        };
        assert!(e.contains(&expected), "{tag}: {e}\nexpected: {expected}");
    }
}

#[test]
fn unsupported_plugin_message_format() {
    let e = build_error(Kind::Shape, r#"<shape type="blender"/>"#).unwrap();
    assert!(
        e.ends_with(
            "shape plugin 'blender' is not supported by Penumbra (it is the mesh Mitsuba's Blender add-on passes in \
             memory, which no scene file can describe; export the mesh as ply or serialized); supported shape plugins: \
             rectangle, cube, sphere, disk, cylinder, ellipsoids, ellipsoidsmesh, sdfgrid, linearcurve, \
             bsplinecurve, obj, ply, serialized, shapegroup, instance, merge"
        ),
        "{e}"
    );
}

/// The README's unsupported plugins fail with their reason.
#[test]
fn unsupported_plugins_say_why() {
    for (kind, object, why) in [
        (
            Kind::Film,
            r#"<sensor type="perspective"><film type="specfilm"/></sensor>"#,
            "Mitsuba's own RGB variants refuse it",
        ),
        (Kind::Bsdf, r#"<bsdf type="polarizer" id="p"/>"#, "Stokes vectors"),
        (Kind::Integrator, r#"<integrator type="stokes"/>"#, "Stokes vectors"),
    ] {
        let e = build_error(kind, object).unwrap_or_else(|| panic!("{object} was accepted"));
        assert!(e.contains("is not supported by Penumbra (") && e.contains(why), "{e}");
    }
}

const README_HEADING: &str = "### Every Mitsuba 3.9.1 plugin";

/// The README rows compared, with the kinds their "supported" cell lists
/// (separated by `;` where a row holds several).
const README_ROWS: &[(&str, &[Kind])] = &[
    ("shapes", &[Kind::Shape]),
    ("bsdfs", &[Kind::Bsdf]),
    ("textures", &[Kind::Texture]),
    ("emitters", &[Kind::Emitter]),
    ("sensors", &[Kind::Sensor]),
    ("samplers", &[Kind::Sampler]),
    ("films, rfilters", &[Kind::Film, Kind::Rfilter]),
    ("integrators", &[Kind::Integrator]),
    ("media, phase, volumes", &[Kind::Medium, Kind::Phase, Kind::Volume]),
];

/// Entries of the code's lists that the README names differently.
const README_NAMES: &[(&str, &str)] = &[
    ("area (inside a shape)", "area"),
    ("directionalarea (inside a shape)", "directionalarea"),
    ("irradiancemeter (inside a shape)", "irradiancemeter"),
];

/// The names in a README "supported" list: comma-separated plugin names, where
/// "direct (and Penumbra's bruteforce)" names direct and bruteforce.
fn readme_names(list: &str) -> Result<BTreeSet<String>, String> {
    let mut names = BTreeSet::new();
    for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (name, extra) = match item.split_once(" (and Penumbra's ") {
            Some((name, rest)) => {
                let extra = rest.strip_suffix(')').ok_or_else(|| format!("cannot read '{item}'"))?;
                (name, Some(extra))
            }
            None => (item, None),
        };
        for n in [Some(name), extra].into_iter().flatten() {
            if n.is_empty() || n.contains(char::is_whitespace) {
                return Err(format!("cannot read '{item}' as a plugin name"));
            }
            names.insert(n.to_string());
        }
    }
    Ok(names)
}

/// The code's list of `kind`, named as the README names the plugins.
fn code_names(kind: Kind) -> BTreeSet<String> {
    supported_plugins(kind)
        .into_iter()
        .map(|entry| README_NAMES.iter().find(|(code, _)| *code == entry).map_or(entry, |&(_, readme)| readme))
        .map(str::to_string)
        .collect()
}

/// Where the README's plugin table and the code disagree, one line each.
fn readme_differences(readme: &str) -> Vec<String> {
    let Some(start) = readme.lines().position(|l| l.trim() == README_HEADING) else {
        return vec![format!("README has no heading '{README_HEADING}'")];
    };
    // The table's rows after its header and separator lines.
    let rows: Vec<Vec<&str>> = readme
        .lines()
        .skip(start + 1)
        .skip_while(|l| !l.trim_start().starts_with('|'))
        .take_while(|l| l.trim_start().starts_with('|'))
        .skip(2)
        .map(|l| l.trim().trim_matches('|').split('|').map(str::trim).collect())
        .collect();
    let mut diffs = Vec::new();
    for &(row, kinds) in README_ROWS {
        let Some(cells) = rows.iter().find(|cells| cells[0] == row) else {
            diffs.push(format!("README's plugin table has no row '{row}'"));
            continue;
        };
        let supported = cells.get(1).copied().unwrap_or("");
        let parts: Vec<&str> = supported.split(';').collect();
        if parts.len() != kinds.len() {
            diffs.push(format!("row '{row}': expected {} ';'-separated lists, found '{supported}'", kinds.len()));
            continue;
        }
        for (&kind, part) in kinds.iter().zip(parts) {
            let readme = match readme_names(part) {
                Ok(names) => names,
                Err(e) => {
                    diffs.push(format!("row '{row}': {e}"));
                    continue;
                }
            };
            let code = code_names(kind);
            let only_readme: Vec<_> = readme.difference(&code).collect();
            let only_code: Vec<_> = code.difference(&readme).collect();
            if !only_readme.is_empty() {
                diffs.push(format!("{}: README lists {only_readme:?}, which the code does not support", kind.tag()));
            }
            if !only_code.is_empty() {
                diffs.push(format!("{}: the code supports {only_code:?}, which README does not list", kind.tag()));
            }
        }
    }
    diffs
}

fn readme() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md");
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn readme_plugin_table_matches_the_code() {
    let diffs = readme_differences(&readme());
    assert!(diffs.is_empty(), "README.md ('{README_HEADING}') and the code disagree:\n{}", diffs.join("\n"));
}

#[test]
fn readme_check_names_each_difference() {
    let readme = readme();
    let changed = readme.replacen("disk, cylinder, ellipsoids", "disk, ellipsoids", 1).replacen(
        "catmullrom, lanczos",
        "catmullrom, lanczos, bessel",
        1,
    );
    assert_ne!(changed, readme, "the README's table changed; update this test's edits");
    let diffs = readme_differences(&changed);
    assert_eq!(diffs.len(), 2, "{diffs:?}");
    assert!(diffs.iter().any(|d| d.starts_with("shape:") && d.contains("\"cylinder\"")), "{diffs:?}");
    assert!(diffs.iter().any(|d| d.starts_with("rfilter:") && d.contains("\"bessel\"")), "{diffs:?}");
    let without_row = readme.replacen("| integrators |", "| integrator |", 1);
    assert!(readme_differences(&without_row).iter().any(|d| d.contains("no row 'integrators'")));
    assert_eq!(readme_differences("# no table"), [format!("README has no heading '{README_HEADING}'")]);
}
