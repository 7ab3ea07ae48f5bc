use std::path::Path;

use super::{Event, Role, load, parse};

fn scene_file(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

#[test]
fn shipped_scenes_load() {
    let crossfire = load(&scene_file("crossfire.toml")).expect("crossfire loads");
    assert_eq!(crossfire.clusters.len(), 2);
    assert!(
        crossfire
            .events
            .iter()
            .any(|e| matches!(e, Event::Handoff { .. }))
    );
    assert!(
        crossfire
            .events
            .iter()
            .any(|e| matches!(e, Event::Explosion { .. }))
    );
    assert_eq!(crossfire.entities[0].role, Role::Fixed);
    let grid = load(&scene_file("grid.toml")).expect("grid loads");
    assert_eq!(grid.clusters.len(), 4);
    let bodies: u64 = grid.entities.iter().map(|e| e.copies()).sum();
    assert_eq!(bodies, 2500, "thousands of entities");
}

const GOOD: &str = r#"name = "t"

[[cluster]]
name = "a"
region = { min = [0, 0, 0], max = [1, 1, 1] }

[[entity]]
name = "e"
owner = "a"
shape = { kind = "ball", radius = 0.5 }
mass = 1.0
position = [0, 0, 0]
"#;

fn error(text: &str) -> String {
    parse("bad.toml", text).expect_err("rejected").to_string()
}

#[test]
fn a_good_scene_parses() {
    let scene = parse("good.toml", GOOD).expect("valid");
    assert_eq!(scene.ticks, 600);
    assert_eq!(scene.entities[0].rotation, [0.0, 0.0, 0.0, 1.0]);
}

#[test]
fn errors_name_file_line_and_field() {
    let wrong_type = GOOD.replace("mass = 1.0", "mass = \"heavy\"");
    let message = error(&wrong_type);
    assert!(message.starts_with("bad.toml:11:"), "{message}");
    assert!(message.contains("mass"), "{message}");

    let missing = GOOD.replace("mass = 1.0\n", "");
    let message = error(&missing);
    assert!(message.starts_with("bad.toml:"), "{message}");
    assert!(message.contains("`mass`"), "{message}");

    let unknown_owner = GOOD.replace("owner = \"a\"", "owner = \"b\"");
    let message = error(&unknown_owner);
    assert!(message.starts_with("bad.toml:9:"), "{message}");
    assert!(
        message.contains("field `owner`") && message.contains("\"b\""),
        "{message}"
    );

    let typo = GOOD.replace("position =", "postion =");
    let message = error(&typo);
    assert!(message.contains("postion"), "{message}");

    let bad_shape = GOOD.replace("radius = 0.5", "radius = -1");
    assert!(error(&bad_shape).contains("`shape`"));

    let bad_region = GOOD.replace("max = [1, 1, 1]", "max = [-1, 1, 1]");
    assert!(error(&bad_region).contains("`region`"));

    let handoff = format!(
        "{GOOD}\n[[event]]\ntick = 5\nkind = \"handoff\"\nentity = \"ghost\"\nto = \"a\"\n"
    );
    let message = error(&handoff);
    assert!(
        message.contains("field `entity`") && message.contains("ghost"),
        "{message}"
    );
    assert!(message.starts_with("bad.toml:17:"), "{message}");
}

#[test]
fn layers_stack_grid_entities() {
    let grid = load(&scene_file("grid.toml")).expect("grid loads");
    assert_eq!(
        grid.clone().stacked(1).expect("one layer").entity_count(),
        2500
    );
    assert_eq!(
        grid.clone().stacked(4).expect("four").entity_count(),
        10_000
    );
    assert!(grid.stacked(0).is_err(), "zero layers refused");
    let flat = parse(
        "flat.toml",
        r#"name = "flat"
[[cluster]]
name = "a"
region = { min = [0, 0, 0], max = [9, 9, 9] }
[[entity]]
name = "tiles"
owner = "a"
shape = { kind = "ball", radius = 0.1 }
mass = 1.0
position = [0, 0, 0]
grid = { count = [3, 1, 3], spacing = [1, 0, 1] }
"#,
    )
    .expect("parses");
    let err = flat
        .stacked(2)
        .expect_err("no y spacing: the layers would overlap");
    assert!(err.to_string().contains("y spacing"), "{err}");
}

#[test]
fn hosts_are_laid_out_or_named() {
    let grid = load(&scene_file("grid.toml")).expect("grid loads");
    assert_eq!(grid.host_layout(None).expect("one host"), ["a"; 4]);
    assert_eq!(
        grid.host_layout(Some(2)).expect("two hosts"),
        ["a", "a", "b", "b"]
    );
    assert_eq!(
        grid.host_layout(Some(3)).expect("three hosts"),
        ["a", "a", "b", "c"]
    );
    assert!(grid.host_layout(Some(0)).is_err());
    assert!(
        grid.host_layout(Some(5)).is_err(),
        "more hosts than clusters"
    );
    let two = |second: &str| {
        parse(
            "hosts.toml",
            &format!(
                r#"name = "h"
[[cluster]]
name = "a"
region = {{ min = [0, 0, 0], max = [9, 9, 9] }}
host = "left"
[[cluster]]
name = "b"
region = {{ min = [9, 0, 0], max = [18, 9, 9] }}
{second}
"#
            ),
        )
        .expect("parses")
    };
    let named = two("host = \"right\"");
    assert_eq!(named.host_layout(None).expect("named"), ["left", "right"]);
    assert_eq!(
        named.host_layout(Some(2)).expect("agrees"),
        ["left", "right"]
    );
    assert!(
        named.host_layout(Some(3)).is_err(),
        "disagrees with the scene"
    );
    let half = two("")
        .host_layout(None)
        .expect_err("one cluster without a host");
    assert!(half.to_string().contains("1 of 2 clusters"), "{half}");
    assert!(
        two("host = \"a/b\"").host_layout(None).is_err(),
        "unusable name"
    );
}

#[test]
fn scenery_has_no_owner_and_needs_no_mass() {
    let scenery = r#"name = "t"

[[cluster]]
name = "a"
region = { min = [0, 0, 0], max = [1, 1, 1] }

[[entity]]
name = "floor"
role = "scenery"
shape = { kind = "cuboid", half_extents = [5, 0.5, 5] }
position = [0, -0.5, 0]
"#;
    let scene = parse("scenery.toml", scenery).expect("valid");
    assert!(scene.entities[0].is_scenery());
    assert!(scene.entities[0].mass() > 0.0);
    let owned = scenery.replace("role = \"scenery\"", "role = \"scenery\"\nowner = \"a\"");
    assert!(
        error(&owned).contains("scenery is owned by no cluster"),
        "{}",
        error(&owned)
    );
    let unowned = GOOD.replace("owner = \"a\"\n", "");
    assert!(
        error(&unowned).contains("field `owner` is required"),
        "{}",
        error(&unowned)
    );
    let massless = GOOD.replace("mass = 1.0\n", "");
    assert!(
        error(&massless).contains("field `mass` is required"),
        "{}",
        error(&massless)
    );
    let handed = format!(
        "{scenery}\n[[event]]\ntick = 1\nkind = \"handoff\"\nentity = \"floor\"\nto = \"a\"\n"
    );
    assert!(error(&handed).contains("is scenery"), "{}", error(&handed));
}

#[test]
fn every_bundled_scene_loads() {
    for name in [
        "crossfire",
        "grid",
        "gallery",
        "stacks",
        "corridor",
        "platform",
        "elevator",
        "dominoes",
        "ramp",
        "open/corner",
        "open/four-corners",
    ] {
        load(&scene_file(&format!("{name}.toml"))).unwrap_or_else(|e| panic!("{e}"));
    }
    load(&scene_file("variants/crossfire-owner-blasts.toml")).expect("the variant loads");
}

#[test]
fn catalog_shapes_and_materials_load_and_bad_ones_say_why() {
    let base = r#"name = "t"
[[cluster]]
name = "a"
region = { min = [-1, -1, -1], max = [1, 1, 1] }

[[entity]]
name = "rock"
owner = "a"
mass = 3.0
position = [0, 0, 0]
friction = 0.9
restitution = 0.4
groups = { memberships = 1, filter = 0xfffffffe }
sensor = true
shape = { kind = "convex_hull", points = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]] }
"#;
    let scene = parse("rock.toml", base).expect("valid");
    let rock = &scene.entities[0];
    assert!((rock.shape.volume() - 1.0 / 6.0).abs() < 1e-4);
    assert_eq!(
        (rock.friction, rock.restitution, rock.sensor),
        (0.9, 0.4, true)
    );
    assert_eq!(rock.groups.map(|g| g.filter), Some(0xffff_fffe));
    let flat = base.replace("[0, 0, 1]]", "[1, 1, 0]]");
    assert!(error(&flat).contains("span no volume"), "{}", error(&flat));
    let field = base.replace(
        r#"{ kind = "convex_hull", points = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]] }"#,
        r#"{ kind = "heightfield", heights = [[0, 0], [0, 1]], size = [2, 1, 2] }"#,
    );
    assert!(error(&field).contains("no volume"), "{}", error(&field));
    let sticky = base.replace("friction = 0.9", "friction = -1.0");
    assert!(error(&sticky).contains("friction"), "{}", error(&sticky));
}
