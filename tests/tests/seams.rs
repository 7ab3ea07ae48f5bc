//! Nothing falls through, nothing flies past: every bundled scene (`bench/scenes/*.toml`) split
//! over its clusters with default settings against the same scene in one world.
//!
//! The classes that used to fail by default: a neighbour's floor not modelled because its
//! centre is far from the seam (`stacks`: crates fell through the world), shots crossing two
//! seams into a cluster that is not the shooter's neighbour (`corridor`: no hit at all),
//! explosions and volleys reaching past the spread (`crossfire`), and hand-offs onto ground the
//! new owner did not model. Trials run in lock-step, so every figure is deterministic.

use std::path::PathBuf;

use seam_bench::accuracy::{Accuracy, TrialSettings, beyond_floor, run_trial};
use seam_bench::node::{AuthorityArg, AuthorityArgs};
use seam_bench::scene::{self, Scene};
use seam_proxy::ProxyMode;

fn scenes() -> Vec<Scene> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../bench/scenes");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("bench/scenes")
        .filter_map(Result::ok)
        .map(|entry| entry.path())
        .filter(|path| path.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    let scenes: Vec<Scene> = paths
        .iter()
        .map(|path| scene::load(path).unwrap_or_else(|e| panic!("{e}")))
        .collect();
    for name in [
        "crossfire",
        "gallery",
        "grid",
        "stacks",
        "corridor",
        "light-on-heavy",
        "equal-masses",
        "seam-stack",
        "platform",
        "terrain",
        "hull-pile",
        "ramp",
        "dominoes",
        "elevator",
    ] {
        assert!(
            scenes.iter().any(|s| s.name == name),
            "bench/scenes has {name}"
        );
    }
    scenes
}

fn trial(scene: &Scene, settings: TrialSettings) -> Accuracy {
    run_trial(scene, &settings, None)
        .unwrap_or_else(|e| panic!("{}: {e}", scene.name))
        .accuracy
}

/// Default settings on every bundled scene: at its noise floor, no body escapes, none has two owners or none, none but a shot is handed to
/// a cluster with no proxy of it, every
/// judged hand-off lands within 1 cm and 0.05 m/s of the single world's motion, the position
/// error is at most 1.25 times that of proxies for everything (so interest management costs
/// no accuracy a scene needs), and the momentum error is within 5 % of Σm|v| beyond the single
/// world's own drift (measured: at most 0.0039 against 0.0012 on `grid`; 0 on
/// `light-on-heavy` and `equal-masses`); on the floor scenes, at most 5 cm RMS.
#[test]
fn bundled_scenes_hold_at_default_settings() {
    for scene in scenes() {
        let name = scene.name.clone();
        let r = run_trial(&scene, &TrialSettings::default(), None)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let misses = beyond_floor(&r.accuracy, &r.floor);
        assert!(misses.is_empty(), "{name}: beyond its floor: {misses:?}");
        let default = r.accuracy;
        let everything = trial(
            &scene,
            TrialSettings {
                interest: false,
                ..TrialSettings::default()
            },
        );
        assert_eq!(default.escaped_bodies, 0, "{name}: {default:?}");
        assert!(
            default.momentum_error_rel <= default.momentum_drift_rel + 0.05,
            "{name}: momentum {} of Σm|v| against the single world's drift {}",
            default.momentum_error_rel,
            default.momentum_drift_rel
        );
        assert_eq!(
            (default.duplicate_owner_ticks, default.missing_entity_ticks),
            (0, 0),
            "{name}: one owner at every tick: {default:?}"
        );
        assert!(
            default.handoff_jump_position_m <= 0.01 && default.handoff_jump_velocity_mps <= 0.05,
            "{name}: hand-offs land where one world is: {default:?}"
        );
        assert!(
            default.position_rms_m <= 1.25 * everything.position_rms_m + 1e-4,
            "{name}: default {} m against everything {} m",
            default.position_rms_m,
            everything.position_rms_m
        );
        // Not `stacks`: its floor is 0.133 m RMS (its three worlds 0.036 to 0.133 m), and
        // the split lands on either side of its chaos (0.009 m, or 0.17 m since each world
        // holds its neighbours' proxies from the first step; free-running 0.011 or 0.34 m),
        // so 5 cm there judged luck.
        if ["corridor", "seam-stack"].contains(&name.as_str()) {
            assert!(
                default.position_rms_m <= 0.05,
                "{name}: floor scene within 5 cm: {default:?}"
            );
        }
        if default.hits_reference == 0 && default.hits_split == 0 {
            // Only a shot fired and handed in one frame is handed to a cluster with no proxy
            // of it (see `seam_proxy::authority`).
            assert_eq!(
                default.handoffs_without_proxy, 0,
                "{name}: every hand-off to a cluster that models the body: {default:?}"
            );
        }
        if let Some(recall) = default.hit_recall {
            assert!(
                recall >= 0.95 && default.hit_precision.is_some_and(|p| p >= 0.9),
                "{name}: hits as in one world: {default:?}"
            );
        }
    }
}

/// No body escapes the world on any bundled scene, with Fixed or kinematic proxies, at a
/// replication every 1, 2, 4 or 8 ticks (`grid` over its first 600 ticks); and with a frame
/// every tick, either mode keeps momentum within 5 % of Σm|v| beyond the single world's drift.
#[test]
fn no_body_escapes_at_any_setting() {
    for scene in scenes() {
        for mode in [ProxyMode::Fixed, ProxyMode::KinematicVelocityBased] {
            for interval in [1, 2, 4, 8] {
                let a = trial(
                    &scene,
                    TrialSettings {
                        proxy_mode: mode,
                        replication_interval: interval,
                        ticks: (scene.name == "grid").then_some(600),
                        ..TrialSettings::default()
                    },
                );
                assert_eq!(
                    (a.escaped_bodies, a.duplicate_owner_ticks),
                    (0, 0),
                    "{} {mode:?} every {interval}: {a:?}",
                    scene.name
                );
                if interval == 1 {
                    assert!(
                        a.momentum_error_rel <= a.momentum_drift_rel + 0.05,
                        "{} {mode:?}: momentum {a:?}",
                        scene.name
                    );
                }
            }
        }
    }
}

/// `seam compare --trace NAME` follows one entity of the scene, a grid copy by `name#i`; a
/// name the scene does not have is an error that says how names look, not a silent run.
#[test]
fn a_trace_names_an_entity_of_the_scene() {
    let scenes = scenes();
    let crossfire = scenes
        .iter()
        .find(|s| s.name == "crossfire")
        .expect("crossfire");
    let settings = TrialSettings {
        ticks: Some(3),
        ..TrialSettings::default()
    };
    for name in ["runner", "crates-east#7"] {
        run_trial(crossfire, &settings, Some(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    for name in ["nobody", "crates-east", "crates-east#99"] {
        let error = run_trial(crossfire, &settings, Some(name))
            .expect_err("an entity the scene does not have")
            .to_string();
        assert!(
            error.contains(name) && error.contains("name#i"),
            "{name}: {error}"
        );
    }
}

/// The noise floor tells chaos from error: on a scene where nothing depends on round-off
/// (`light-on-heavy`: one ball bounced off a heavy crate, nothing piled) a second single world
/// perturbed at round-off stays within 0.1 mm of the first and never departs by 2 cm; on a
/// chaotic one (`crossfire`: volleys into crate stacks) it ends metres off and departs at a
/// tick the report names. The split's own onset is reported beside the floor's: `crossfire`
/// split never departs with the exchange of routed ops before the step, and departs, before
/// the floor does, with its volleys landing a tick late (`exchange` off).
#[test]
fn the_noise_floor_is_zero_where_calm_and_not_where_chaotic() {
    let scenes = scenes();
    let run = |name: &str, exchange: bool| {
        let scene = scenes.iter().find(|s| s.name == name).expect(name);
        let settings = TrialSettings {
            exchange,
            ..TrialSettings::default()
        };
        run_trial(scene, &settings, None).unwrap_or_else(|e| panic!("{name}: {e}"))
    };
    let calm = run("light-on-heavy", true);
    assert!(
        calm.floor.position_max_m < 1e-4 && calm.floor.onset_tick.is_none(),
        "calm scene, floor ~0: {:?}",
        calm.floor
    );
    let chaotic = run("crossfire", true);
    assert!(
        chaotic.floor.position_rms_m > 0.1 && chaotic.floor.onset_tick.is_some(),
        "chaotic scene, a floor of its own: {:?}",
        chaotic.floor
    );
    assert_eq!(
        chaotic.accuracy.onset_tick, None,
        "pushes on their tick: {:?}",
        chaotic.accuracy
    );
    let late = run("crossfire", false);
    let onset = late
        .accuracy
        .onset_tick
        .expect("the split departs on crossfire with its pushes a tick late");
    assert!(
        onset <= late.ticks && late.accuracy.position_max_m >= seam_bench::accuracy::ONSET_M,
        "an onset is a tick of the run where a body was 2 cm off: {:?}",
        late.accuracy
    );
    assert!(
        !beyond_floor(&late.accuracy, &late.floor).is_empty(),
        "a tick late is beyond the floor: {:?}",
        late.accuracy
    );
}

/// A platform its owner moves kinematically carries a stack and a crate across two seams and
/// back, handed from west to middle to east and back to middle: in either proxy mode the
/// riders stay where one world has them, to its noise floor (before: proxied as a Fixed body
/// with no velocity, the platform slid out from under them, 14 m RMS; taken over as a Fixed
/// body it stopped), and the platform itself is exact.
#[test]
fn a_platform_carries_its_riders_across_the_seams() {
    let scenes = scenes();
    let scene = scenes
        .iter()
        .find(|s| s.name == "platform")
        .expect("platform");
    for mode in [ProxyMode::Fixed, ProxyMode::KinematicVelocityBased] {
        let settings = TrialSettings {
            proxy_mode: mode,
            ..TrialSettings::default()
        };
        let r = run_trial(scene, &settings, None).unwrap_or_else(|e| panic!("{mode:?}: {e}"));
        let misses = beyond_floor(&r.accuracy, &r.floor);
        assert!(misses.is_empty(), "{mode:?}: {misses:?}: {:?}", r.accuracy);
        assert!(
            r.accuracy.handoffs >= 4,
            "{mode:?}: the platform and its riders are handed along: {:?}",
            r.accuracy
        );
        assert_eq!(
            (
                r.accuracy.duplicate_owner_ticks,
                r.accuracy.missing_entity_ticks
            ),
            (0, 0),
            "{mode:?}: one owner at every tick"
        );
    }
}

/// Four clusters at a corner (`bench/scenes/open/corner.toml`: a stack on the corner point
/// whose crates the four own in turn, 200 m/s shots diagonally through it): with the default
/// authority, which gives one owner to bodies in sustained contact where three or more
/// clusters' bodies meet, the split is at its noise floor in position (RMS, max, onset) and
/// hits as many shots as a second single world does; with the spatial rule alone the stack
/// is solved in four worlds at once, and a crate escapes (5.1 m RMS against 3.9; 13.8 m
/// while proxies at rest kept the stack from ever falling asleep).
#[test]
fn four_clusters_at_a_corner_are_at_their_floor_with_groups() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../bench/scenes/open/corner.toml");
    let scene = scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let grouped = run_trial(&scene, &TrialSettings::default(), None).expect("corner");
    let misses = beyond_floor(&grouped.accuracy, &grouped.floor);
    assert!(misses.is_empty(), "with groups: {misses:?}");
    let (a, f) = (&grouped.accuracy, &grouped.floor);
    assert!(
        a.hit_recall
            .zip(f.hit_recall)
            .is_some_and(|(s, r)| s >= r - 0.1),
        "hits as the floor's: {a:?} against {f:?}"
    );
    assert_eq!(
        (a.duplicate_owner_ticks, a.missing_entity_ticks),
        (0, 0),
        "one owner at every tick: {a:?}"
    );
    let spatial = TrialSettings {
        authority: AuthorityArgs {
            authority: AuthorityArg::Spatial,
            ..AuthorityArgs::default()
        },
        ..TrialSettings::default()
    };
    let alone = run_trial(&scene, &spatial, None).expect("corner, spatial");
    assert!(
        !beyond_floor(&alone.accuracy, &alone.floor).is_empty()
            || alone.accuracy.escaped_bodies > 0,
        "the spatial rule alone: {:?}",
        alone.accuracy
    );
    // A stack toppling at the corner: groups are for bodies at rest against each other, so
    // nothing is handed over mid-collision (before that rule: 1.02 m against a floor of 0.21).
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../bench/scenes/variants/corner-topple.toml");
    let topple = scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let r = run_trial(&topple, &TrialSettings::default(), None).expect("corner-topple");
    let misses = beyond_floor(&r.accuracy, &r.floor);
    assert!(misses.is_empty(), "a toppling stack: {misses:?}");
}

/// Four clusters at a corner judged absolutely (`bench/scenes/open/four-corners.toml`: four
/// heavy crates turned 45° stacked on the corner point, one per cluster, shots along the
/// diagonals square onto their faces, shots across two seams beside it). The absolute
/// targets hold, whatever the floor: RMS within 1 cm, max within 5 cm, never 2 cm off one
/// world, every hit matched, every hand-off within 1 cm of one world's motion, one owner at
/// every tick. (Measured: 0.4 mm RMS, 3.2 mm max; before the split let the stack fall asleep
/// as one world does, 3.3 / 8.2 mm. The floor is 0.2 mm to 2.3 cm RMS by the direction its
/// bodies are moved: the stack starts face on face, and two directions of three set it
/// rocking by tick 2.)
#[test]
fn four_clusters_at_a_corner_meet_the_absolute_targets() {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../bench/scenes/open/four-corners.toml");
    let scene = scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let r = run_trial(&scene, &TrialSettings::default(), None).expect("four-corners");
    let a = &r.accuracy;
    assert!(a.position_rms_m <= 0.01, "RMS: {a:?}");
    assert!(a.position_max_m <= 0.05, "max: {a:?}");
    assert_eq!(a.onset_tick, None, "never departs: {a:?}");
    assert!(a.hits_reference > 0, "shots hit: {a:?}");
    assert_eq!(a.hit_recall, Some(1.0), "recall: {a:?}");
    assert_eq!(a.hit_precision, Some(1.0), "precision: {a:?}");
    assert!(a.handoffs > 0, "bodies are handed: {a:?}");
    assert!(a.handoff_jump_position_m <= 0.01, "hand-off jump: {a:?}");
    assert_eq!(
        (
            a.duplicate_owner_ticks,
            a.missing_entity_ticks,
            a.escaped_bodies
        ),
        (0, 0, 0),
        "one owner at every tick, nothing escapes: {a:?}"
    );
}
