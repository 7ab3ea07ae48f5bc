use super::*;
use crate::scene::Scene;

fn scene() -> Scene {
    crate::scene::parse(
        "tiny.toml",
        r#"
name = "tiny"
ticks = 10
[[cluster]]
name = "west"
region = { min = [-10.0, -5.0, -10.0], max = [0.0, 10.0, 10.0] }
[[cluster]]
name = "east"
region = { min = [0.0, -5.0, -10.0], max = [10.0, 10.0, 10.0] }
[[entity]]
name = "floor"
role = "scenery"
shape = { kind = "cuboid", half_extents = [10.0, 0.5, 10.0] }
position = [0.0, -0.5, 0.0]
[[entity]]
name = "ball"
owner = "west"
shape = { kind = "ball", radius = 0.5 }
mass = 1.0
position = [-1.0, 1.0, 0.0]
grid = { count = [2, 1, 2], spacing = [1.0, 0.0, 1.0] }
[[event]]
tick = 2
every = 3
kind = "projectile"
by = "east"
position = [5.0, 1.0, 0.0]
velocity = [-10.0, 0.0, 0.0]
radius = 0.1
mass = 0.1
"#,
    )
    .expect("scene")
}

fn table(reference: bool) -> EntityTable {
    EntityTable::new(&scene(), "run", 10, 60.0, "test", reference)
}

fn tick(stream: u16, tick: u64, owned: &[(u32, [i32; 3])], proxies: &[u32]) -> Chunk {
    Chunk::Tick(StreamTick {
        stream,
        tick,
        tick_us: 1234,
        owned: owned
            .iter()
            .map(|&(entity, mm)| OwnedPose {
                entity,
                mm,
                heading: 7,
            })
            .collect(),
        proxies: proxies.to_vec(),
        ops: vec![RecordedOp {
            from: Some(1),
            target: 2,
            ticks_late: 1,
        }],
        contacts: vec![RecordedContact {
            a: 1,
            b: 5,
            started: true,
            reporter: None,
        }],
        handoffs: vec![
            RecordedHandoff {
                entity: 3,
                taken: true,
            },
            RecordedHandoff {
                entity: 3,
                taken: false,
            },
        ],
    })
}

fn bytes_of(header: &Header, chunks: &[Chunk]) -> Vec<u8> {
    let mut out = Vec::new();
    write_header(&mut out, header).expect("header");
    let mut encoder = ChunkEncoder::new(header);
    for chunk in chunks {
        encoder.write(&mut out, chunk).expect("chunk");
    }
    out
}

#[test]
fn the_table_numbers_scene_entities_then_projectile_shots() {
    let t = table(true);
    let h = &t.header;
    // floor, 4 balls, shots at ticks 2, 5 and 8.
    assert_eq!(h.entities, 1 + 4 + 3);
    assert_eq!(h.streams, ["west", "east", "reference"]);
    assert_eq!(h.reference_stream(), Some(2));
    assert_eq!(h.entity_name(2), "ball#1");
    assert_eq!(h.entity_index("ball#3"), Some(4));
    assert_eq!(h.entity_index("floor"), Some(0));
    assert_eq!(h.entity_name(7), "projectile 0#2");
    assert_eq!(h.scenery.len(), 1);
    let ids = crate::pod::SceneIds::new("run", "tiny");
    assert_eq!(t.entities[&ids.entity("ball", 3)], 4);
    assert_eq!(t.entities[&ids.event_entity(0, 2)], 7);
    assert_eq!(t.streams.len(), 3);
}

#[test]
fn chunks_come_back_as_written_with_positions_as_changes() {
    let header = table(false).header;
    let chunks = vec![
        tick(0, 1, &[(1, [-1000, 1000, 0]), (2, [0, 1000, 0])], &[5]),
        tick(1, 1, &[(5, [5000, 1000, -3])], &[1, 2]),
        // Entity 1 moves a little (a change), 3 appears (whole), 2 leaves.
        tick(0, 2, &[(1, [-999, 990, 1]), (3, [-1000, 1000, 1000])], &[]),
        Chunk::Fault(Fault {
            tick: 2,
            stream: Some(1),
            what: "killed".into(),
        }),
        // 2 comes back after a chunk away: whole again.
        tick(0, 3, &[(1, [-998, 980, 2]), (2, [7, 7, 7])], &[]),
    ];
    let bytes = bytes_of(&header, &chunks);
    let read = Recording::parse(&bytes).expect("parse");
    assert_eq!(read.header, header);
    assert_eq!(read.chunks, chunks);
    assert!(!read.cut_short);
    assert_eq!(read.owner_at(5, 1), Some(1));
    assert_eq!(read.owner_at(2, 2), None);
}

#[test]
fn a_cut_short_file_keeps_its_whole_chunks_and_unknown_kinds_are_skipped() {
    let header = table(false).header;
    let chunks = vec![
        tick(0, 1, &[(1, [1, 2, 3])], &[]),
        tick(0, 2, &[(1, [1, 2, 4])], &[]),
    ];
    let mut bytes = bytes_of(&header, &chunks[..1]);
    // A chunk of a kind from the future.
    bytes.extend_from_slice(&[99, 3, 0, 0, 0, 1, 2, 3]);
    let whole = bytes_of(&header, &chunks);
    let head = bytes_of(&header, &chunks[..1]).len();
    bytes.extend_from_slice(&whole[head..whole.len() - 2]);
    let read = Recording::parse(&bytes).expect("parse");
    assert_eq!(read.chunks, chunks[..1]);
    assert_eq!(read.skipped, 1);
    assert!(read.cut_short);
}

#[test]
fn garbage_is_an_error_not_a_panic() {
    let header = table(false).header;
    assert!(matches!(
        Recording::parse(b"not a recording at all"),
        Err(RecordError::NotARecording)
    ));
    let good = bytes_of(&header, &[tick(0, 1, &[(1, [1, 2, 3])], &[4])]);
    let head = bytes_of(&header, &[]).len();
    // Flip every byte of the chunk in turn: each parse returns, whatever it says.
    for at in head..good.len() {
        for value in [0u8, 0x7f, 0x80, 0xff] {
            let mut bad = good.clone();
            bad[at] = value;
            let _ = Recording::parse(&bad);
        }
    }
    // Random damage to a recording of several chunks (bytes changed, cut, doubled): every
    // parse returns, and whatever it returns has only entities and streams the header names.
    let chunks: Vec<Chunk> = (1..6)
        .flat_map(|t| {
            [
                tick(0, t, &[(1, [t as i32, 2, 3]), (2, [4, 5, 6])], &[5]),
                tick(1, t, &[(5, [7, 8, 9])], &[1, 2]),
            ]
        })
        .collect();
    let whole = bytes_of(&header, &chunks);
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move |bound: usize| {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 33) as usize % bound.max(1)
    };
    for _ in 0..20_000 {
        let mut bad = whole.clone();
        for _ in 0..1 + next(4) {
            let at = head + next(bad.len() - head);
            match next(3) {
                0 => bad[at] = next(256) as u8,
                1 => bad.truncate(at),
                _ => {
                    let piece = bad[at..(at + next(16)).min(bad.len())].to_vec();
                    bad.splice(at..at, piece);
                }
            }
            if bad.len() <= head {
                break;
            }
        }
        if let Ok(read) = Recording::parse(&bad) {
            for chunk in &read.chunks {
                if let Chunk::Tick(t) = chunk {
                    assert!(usize::from(t.stream) < header.streams.len());
                    assert!(t.owned.iter().all(|p| p.entity < header.entities));
                    assert!(t.proxies.iter().all(|&e| e < header.entities));
                    assert!(t.owned.windows(2).all(|w| w[0].entity < w[1].entity));
                }
            }
        }
    }
    // An entity beyond the table is refused by the writer.
    let mut out = Vec::new();
    let wrong = tick(0, 1, &[(header.entities, [0; 3])], &[]);
    assert!(ChunkEncoder::new(&header).write(&mut out, &wrong).is_err());
}

#[test]
fn parts_merge_in_tick_order_with_faults() {
    let dir = std::env::temp_dir().join(format!("seam-record-merge-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let header = table(false).header;
    let west = vec![
        tick(0, 1, &[(1, [1, 1, 1])], &[]),
        tick(0, 2, &[(1, [2, 2, 2])], &[]),
    ];
    let east = vec![
        tick(1, 1, &[(5, [3, 3, 3])], &[]),
        tick(1, 2, &[(5, [4, 4, 4])], &[]),
    ];
    std::fs::write(dir.join("west-1.part"), bytes_of(&header, &west)).expect("write");
    std::fs::write(dir.join("east-1.part"), bytes_of(&header, &east)).expect("write");
    let fault = Fault {
        tick: 2,
        stream: Some(1),
        what: "stopped".into(),
    };
    let out = dir.join("run.rec");
    let parts = part_files(&dir).expect("parts");
    assert_eq!(parts.len(), 2);
    let summary =
        merge_parts(&parts, std::slice::from_ref(&fault), "seam run", &out).expect("merge");
    assert_eq!(summary.chunks, 5);
    let read = Recording::read(&out).expect("read");
    assert_eq!(read.header.source, "seam run");
    let order: Vec<u64> = read.chunks.iter().map(Chunk::tick).collect();
    assert_eq!(order, [1, 1, 2, 2, 2]);
    assert!(read.chunks.contains(&Chunk::Fault(fault)));
    assert!(read.chunks.contains(&west[1]) && read.chunks.contains(&east[1]));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn headings_turn_with_the_body() {
    assert_eq!(heading([0.0, 0.0, 0.0, 1.0]), 0);
    // A quarter turn about y takes x to −z: −64 steps.
    let h = std::f32::consts::FRAC_PI_4;
    assert_eq!(heading([0.0, h.sin(), 0.0, h.cos()]), 192);
}
