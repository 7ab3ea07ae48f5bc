//! Who owned each entity at every tick of a run, across its pods.
//!
//! Each pod writes into its ledger, as it ticks, a line for every entity it starts or stops
//! owning ([`OwnerLog`], from `seam_proxy::Cluster::owned`, where a body handed over counts as
//! the giver's through the tick whose frame hands it and as the taker's from the next, however
//! late the taker's frame arrived). [`check`] reads every life's lines and walks each entity
//! tick by tick from the first tick anyone owned it to the end of the run:
//!
//! - owned by one pod: as it must be;
//! - by none, after its last owner was killed and before a neighbour adopted it (a neighbour
//!   is taken for dead only after `neighbour_timeout_ticks` of silence): **awaiting
//!   adoption**, what killing a pod costs, counted apart;
//! - by two, one of them an adopter of a pod that was only stalled (stopped, or starved of
//!   CPU), or a giver that took back a hand-off the stalled pod did not answer in time (it woke
//!   still owning its copy, and the other copy stops when it hands it back): **across a
//!   stall**, counted apart;
//! - by none, between a hand-off made across a stop and the adoption that ends it: **handed
//!   across a stall**, counted apart. A stopped pod runs the ticks it missed as it catches up,
//!   and a hand-off it makes in them reaches a neighbour that has meanwhile taken it for dead
//!   and adopted the body from its last picture, so the hand-off is never taken (the adopter
//!   owns the body already) and the adopter's copy counts from its adoption; a hand-off to a
//!   pod stopped before it read it is never taken either, and its giver takes it back when it
//!   takes the pod for dead. Either way the body sat in a stalled pod, as a killed pod's bodies
//!   await adoption;
//! - by none otherwise: **unowned**, a lost body while it lasts;
//! - by two otherwise: **owned twice**.
//!
//! Lines: `owner + ENTITY FIRST_TICK HOW` (`HOW`: `own` for a body it spawned or held from the
//! start, `taken` for a hand-off in, `adopted` from a neighbour taken for dead) and
//! `owner - ENTITY LAST_TICK`, the entity in 32 hex digits.

use std::collections::HashMap;
use std::io;

use seam_proxy::{Cluster, ClusterEvent, TickEvent};
use seam_sim::wire::{ClusterId, EntityId, IdMap};
use serde::Serialize;

use crate::ledger::{HEADER, Life, OWNER_PREFIX as PREFIX};

/// How a pod came to own an entity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum How {
    Own,
    Taken,
    Adopted,
}

impl How {
    fn word(self) -> &'static str {
        match self {
            How::Own => "own",
            How::Taken => "taken",
            How::Adopted => "adopted",
        }
    }

    fn parse(word: &str) -> Option<Self> {
        [How::Own, How::Taken, How::Adopted]
            .into_iter()
            .find(|how| how.word() == word)
    }
}

/// A pod's side: what it owned at its last tick, to write what changed.
#[derive(Debug, Default)]
pub struct OwnerLog {
    owned: IdMap<EntityId, ()>,
    last_tick: Option<u64>,
    /// Where each entity was last handed (from `HandoffGiven`), for its `-` line.
    handed: IdMap<EntityId, ClusterId>,
}

impl OwnerLog {
    /// The lines for what `cluster` owns now (between ticks) against what it owned at its last
    /// tick; `events` are the events of the tick just run (for how each came).
    pub fn lines(&mut self, cluster: &Cluster, events: &[TickEvent]) -> Vec<String> {
        let tick = cluster.sim().tick();
        for e in events {
            if let ClusterEvent::HandoffGiven { entity, to } = e.event {
                self.handed.insert(entity, to);
            }
        }
        let now: IdMap<EntityId, ()> = cluster.owned().map(|id| (id, ())).collect();
        let mut lines = Vec::new();
        for id in now.keys() {
            if self.owned.contains_key(id) {
                continue;
            }
            let (first, how) = came(*id, tick, events);
            lines.push(format!(
                "{PREFIX}+ {:032x} {first} {}",
                id.as_u128(),
                how.word()
            ));
        }
        let last = self.last_tick.unwrap_or(tick);
        for id in self.owned.keys().filter(|id| !now.contains_key(*id)) {
            let mut line = format!("{PREFIX}- {:032x} {last}", id.as_u128());
            if let Some(to) = self.handed.swap_remove(id) {
                line += &format!(" {:032x}", to.as_u128());
            }
            lines.push(line);
        }
        self.handed.retain(|id, _| now.contains_key(id));
        self.owned = now;
        self.last_tick = Some(tick);
        lines
    }
}

/// How `entity`, owned here from `tick` on, came: the tick a hand-off in counts from.
fn came(entity: EntityId, tick: u64, events: &[TickEvent]) -> (u64, How) {
    for e in events {
        match e.event {
            ClusterEvent::HandoffTaken {
                entity: id, since, ..
            } if id == entity => return (since.min(tick), How::Taken),
            // Adopted from a neighbour taken for dead, or a hand-off to it taken back: if the
            // neighbour was only stalled, it still owns its copy until it is handed back.
            // So for a hand-off a live neighbour did not answer in time, taken back: it may
            // have been stalled, and take it as it wakes.
            ClusterEvent::EntityAdopted { entity: id, .. }
            | ClusterEvent::HandoffReclaimed { entity: id, .. }
            | ClusterEvent::HandoffReturned { entity: id, .. }
                if id == entity =>
            {
                return (tick, How::Adopted);
            }
            _ => {}
        }
    }
    (tick, How::Own)
}

/// What [`check`] found, in entity-ticks (one entity at one tick).
#[derive(Debug, Clone, Default, Serialize)]
pub struct OwnerCheck {
    /// Entities followed.
    pub entities: usize,
    /// Entity-ticks walked.
    pub entity_ticks: u64,
    /// Owned by exactly one pod.
    pub owned_once: u64,
    /// Owned by none while the last owner was killed and not yet taken for dead.
    pub awaiting_adoption: u64,
    /// Owned by a stalled pod and its adopter (or the giver that took back its hand-off) at
    /// once.
    pub across_a_stall: u64,
    /// Owned by none between a hand-off made while its giver or its taker was stopped and the
    /// adoption (or taking back) that ends it.
    pub handed_across_a_stall: u64,
    /// Owned by none otherwise: lost while it lasts.
    pub unowned: u64,
    /// Owned by two otherwise.
    pub owned_twice: u64,
    /// A few unowned or doubled entities, with the ticks and lives, to start tracing from.
    pub examples: Vec<String>,
    /// Owner lines that did not read.
    pub unreadable_lines: u64,
}

impl OwnerCheck {
    /// Whether every entity had exactly one owner at every tick but for what faults explain.
    pub fn holds(&self) -> bool {
        self.unowned == 0 && self.owned_twice == 0 && self.unreadable_lines == 0
    }
}

/// One life's ownership of one entity: from its first tick to its last, inclusive.
#[derive(Debug, Clone, Copy)]
struct Span {
    life: usize,
    from: u64,
    to: u64,
    how: How,
    /// The cluster it was handed to at its end, if it ended in a hand-off.
    handed_to: Option<u128>,
}

/// At most this many examples.
const EXAMPLES: usize = 5;

/// Reads the owner lines of `lives` and walks every entity tick by tick up to `end_tick` (the
/// run's last tick). A killed life owned what it held until the last tick it was seen to
/// finish; the others until `end_tick`.
pub fn check(lives: &[Life], end_tick: u64) -> io::Result<OwnerCheck> {
    let mut out = OwnerCheck::default();
    let Read {
        spans,
        clusters,
        killed,
    } = read(lives, end_tick, &mut out.unreadable_lines)?;
    out.entities = spans.len();
    let mut ids: Vec<&u128> = spans.keys().collect();
    ids.sort();
    let run = Run {
        lives,
        clusters: &clusters,
        killed: &killed,
        end_tick,
    };
    for id in ids {
        walk(*id, &spans[id], &run, &mut out);
    }
    Ok(out)
}

/// The lives of a run, the cluster whose each is, when each killed one was killed, and the
/// run's last tick.
struct Run<'a> {
    lives: &'a [Life],
    clusters: &'a [Option<u128>],
    /// A killed life's last tick: the later of the last tick it was seen to finish and the
    /// last tick its ledger names (progress lines come about once a second).
    killed: &'a [Option<u64>],
    end_tick: u64,
}

/// What [`read`] gathers.
struct Read {
    spans: HashMap<u128, Vec<Span>>,
    clusters: Vec<Option<u128>>,
    killed: Vec<Option<u64>>,
}

/// Each entity's spans, from every life's owner lines, each life's cluster (from its
/// ledger's first line) and, for a killed one, its last tick.
fn read(lives: &[Life], end_tick: u64, unreadable: &mut u64) -> io::Result<Read> {
    let mut spans: HashMap<u128, Vec<Span>> = HashMap::new();
    let mut clusters = vec![None; lives.len()];
    let mut killed: Vec<Option<u64>> = lives.iter().map(|l| l.killed_after).collect();
    for (life, lived) in lives.iter().enumerate() {
        let text = match std::fs::read_to_string(&lived.path) {
            Ok(text) => text,
            Err(e) if e.kind() == io::ErrorKind::NotFound => continue,
            Err(e) => return Err(e),
        };
        if let Some(after) = lived.killed_after {
            let seen = whole_lines(&text)
                .filter_map(|line| {
                    let words: Vec<&str> = line.split(' ').collect();
                    match words.as_slice() {
                        ["owner", _, _, tick, ..] => tick.parse::<u64>().ok(),
                        [tick, ..] => tick.parse::<u64>().ok(),
                        [] => None,
                    }
                })
                .max();
            killed[life] = Some(seen.map_or(after, |seen| seen.max(after)));
        }
        let last = killed[life].unwrap_or(end_tick).min(end_tick);
        let mut open: HashMap<u128, (u64, How)> = HashMap::new();
        for line in whole_lines(&text) {
            if let Some(cluster) = line.strip_prefix(HEADER) {
                clusters[life] = u128::from_str_radix(cluster, 16).ok();
                continue;
            }
            let Some(rest) = line.strip_prefix(PREFIX) else {
                continue;
            };
            let words: Vec<&str> = rest.split(' ').collect();
            let parsed = match words.as_slice() {
                ["+", id, tick, how] => u128::from_str_radix(id, 16)
                    .ok()
                    .zip(tick.parse::<u64>().ok())
                    .zip(How::parse(how))
                    .map(|((id, tick), how)| {
                        open.insert(id, (tick, how));
                    }),
                ["-", id, tick, rest @ ..] if rest.len() <= 1 => u128::from_str_radix(id, 16)
                    .ok()
                    .zip(tick.parse::<u64>().ok())
                    .zip(match rest {
                        [to] => u128::from_str_radix(to, 16).ok().map(Some),
                        _ => Some(None),
                    })
                    .map(|((id, tick), handed_to)| {
                        if let Some((from, how)) = open.remove(&id) {
                            let to = tick.min(last);
                            spans.entry(id).or_default().push(Span {
                                life,
                                from,
                                to,
                                how,
                                handed_to,
                            });
                        }
                    }),
                _ => None,
            };
            *unreadable += u64::from(parsed.is_none());
        }
        for (id, (from, how)) in open {
            spans.entry(id).or_default().push(Span {
                life,
                from,
                to: last,
                how,
                handed_to: None,
            });
        }
    }
    Ok(Read {
        spans,
        clusters,
        killed,
    })
}

/// Only whole lines: what follows the last newline was cut short by a kill.
fn whole_lines(text: &str) -> std::str::Lines<'_> {
    text.rfind('\n').map_or("", |end| &text[..end]).lines()
}

/// Walks one entity from the first tick a life owned it to `end_tick`.
fn walk(id: u128, spans: &[Span], run: &Run<'_>, out: &mut OwnerCheck) {
    let (lives, end_tick) = (run.lives, run.end_tick);
    let Some(start) = spans.iter().map(|s| s.from).min() else {
        return;
    };
    let mut wrong: Option<(u64, u64, &'static str)> = None;
    for tick in start..=end_tick {
        let owners: Vec<&Span> = spans
            .iter()
            .filter(|s| s.from <= tick && tick <= s.to)
            .collect();
        out.entity_ticks += 1;
        let what = match owners.len() {
            1 => {
                out.owned_once += 1;
                None
            }
            0 if after_a_kill(spans, run, tick) => {
                out.awaiting_adoption += 1;
                None
            }
            0 if handed_across_a_stall(spans, run, tick) => {
                out.handed_across_a_stall += 1;
                None
            }
            0 => {
                out.unowned += 1;
                Some("unowned")
            }
            // A copy taken over from a silent neighbour beside that neighbour's own: it was
            // stalled (stopped, or starved of CPU) and woke still owning it.
            _ if owners.iter().any(|s| s.how == How::Adopted) => {
                out.across_a_stall += 1;
                None
            }
            _ => {
                out.owned_twice += 1;
                Some("owned twice")
            }
        };
        wrong = match (wrong, what) {
            (Some((from, _, kind)), Some(now)) if kind == now => Some((from, tick, kind)),
            (None, Some(now)) => Some((tick, tick, now)),
            (before, now) => {
                if let Some(span) = before {
                    example(id, span, spans, lives, out);
                }
                now.map(|now| (tick, tick, now))
            }
        };
    }
    if let Some(span) = wrong {
        example(id, span, spans, lives, out);
    }
}

/// Ticks before its kill a pod may still be handed a body it then never takes (its
/// neighbours take it for dead only after `neighbour_timeout_ticks` of silence; twice the
/// default, for pods catching up).
const HANDED_TO_THE_DEAD: u64 = 120;

/// Whether the latest span to end before `tick` was a killed life's, ended at its kill; or
/// ended in a hand-off to a cluster whose life was killed around then (in transit to a dead
/// pod, taken back when it is taken for dead).
fn after_a_kill(spans: &[Span], run: &Run<'_>, tick: u64) -> bool {
    let Some(last) = spans.iter().filter(|s| s.to < tick).max_by_key(|s| s.to) else {
        return false;
    };
    if run.killed[last.life] == Some(last.to) {
        return true;
    }
    let Some(to) = last.handed_to else {
        return false;
    };
    run.killed
        .iter()
        .zip(run.clusters)
        .any(|(killed, &cluster)| {
            cluster == Some(to)
                && killed.is_some_and(|killed| {
                    killed < tick && killed <= last.to + 5 && killed + HANDED_TO_THE_DEAD >= last.to
                })
        })
}

/// Ticks before a pod's stop a hand-off to it may still be unread when it stops.
const STOP_SLACK: u64 = 5;

/// Whether `tick` falls between a hand-off made across a stall and the adoption that ends it:
/// the latest span to end before `tick` ended in a hand-off while its giver was stopped (a tick
/// it ran catching up) or its taker was, and the next span to begin is an adoption (the
/// taker's, of the stalled giver's body, or the giver's, taking back what a stalled taker
/// never took).
fn handed_across_a_stall(spans: &[Span], run: &Run<'_>, tick: u64) -> bool {
    let Some(last) = spans.iter().filter(|s| s.to < tick).max_by_key(|s| s.to) else {
        return false;
    };
    let Some(to) = last.handed_to else {
        return false;
    };
    let adopted_next = spans
        .iter()
        .filter(|s| s.from >= tick)
        .min_by_key(|s| s.from)
        .is_some_and(|s| s.how == How::Adopted);
    let stopped_then = |life: &Life| {
        life.stopped
            .iter()
            .any(|&(from, until)| from <= last.to + STOP_SLACK && last.to <= until)
    };
    adopted_next
        && (stopped_then(&run.lives[last.life])
            || run
                .lives
                .iter()
                .zip(run.clusters)
                .any(|(life, &cluster)| cluster == Some(to) && stopped_then(life)))
}

fn example(
    id: u128,
    (from, to, kind): (u64, u64, &'static str),
    spans: &[Span],
    lives: &[Life],
    out: &mut OwnerCheck,
) {
    if out.examples.len() >= EXAMPLES {
        return;
    }
    let owners: Vec<String> = spans
        .iter()
        .map(|s| {
            let name = lives[s.life]
                .path
                .file_stem()
                .map_or_else(|| s.life.to_string(), |n| n.to_string_lossy().into_owned());
            format!("{name} {}..={} ({})", s.from, s.to, s.how.word())
        })
        .collect();
    out.examples.push(format!(
        "{id:032x} {kind} at ticks {from}..={to}; owners: {}",
        owners.join(", ")
    ));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn life(dir: &std::path::Path, name: &str, lines: &[&str], killed_after: Option<u64>) -> Life {
        let path = dir.join(format!("{name}.ledger"));
        let cluster = name
            .bytes()
            .fold(0u128, |h, b| h * 31 + u128::from(b) % 7 + 1);
        let mut text = format!("{HEADER}{cluster:032x}\n");
        text += &lines.join("\n");
        text.push('\n');
        std::fs::write(&path, text).expect("write");
        Life {
            path,
            killed_after,
            stopped: Vec::new(),
        }
    }

    /// A directory of the test's own.
    fn dir(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("seam-owners-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        dir
    }

    fn id(n: u128) -> String {
        format!("{n:032x}")
    }

    #[test]
    fn a_hand_off_counted_gap_free_holds_and_a_gap_or_a_double_does_not() {
        let dir = dir("hand-off");
        let e = id(7);
        let west = life(
            &dir,
            "west-0",
            &[&format!("owner + {e} 1 own"), &format!("owner - {e} 10")],
            None,
        );
        let east = life(&dir, "east-1", &[&format!("owner + {e} 11 taken")], None);
        let found = check(&[west.clone(), east], 20).expect("check");
        assert!(found.holds(), "{found:?}");
        assert_eq!(found.owned_once, 20);

        let late = life(&dir, "east-2", &[&format!("owner + {e} 13 taken")], None);
        let found = check(&[west.clone(), late], 20).expect("check");
        assert_eq!(found.unowned, 2, "{found:?}");
        assert!(!found.holds());
        assert!(
            found.examples[0].contains("unowned at ticks 11..=12"),
            "{found:?}"
        );

        let early = life(&dir, "east-3", &[&format!("owner + {e} 9 taken")], None);
        let found = check(&[west, early], 20).expect("check");
        assert_eq!(found.owned_twice, 2, "{found:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_killed_owner_leaves_its_bodies_awaiting_adoption_not_lost() {
        let dir = dir("kill");
        let e = id(9);
        let killed = life(&dir, "west-0", &[&format!("owner + {e} 1 own")], Some(30));
        let adopter = life(&dir, "east-1", &[&format!("owner + {e} 91 adopted")], None);
        let found = check(&[killed, adopter], 100).expect("check");
        assert!(found.holds(), "{found:?}");
        assert_eq!(found.awaiting_adoption, 60);
        assert_eq!(found.owned_once, 40);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_body_in_transit_to_a_killed_pod_awaits_adoption_not_loss() {
        let dir = dir("transit");
        let e = id(11);
        let dead = life(&dir, "east", &[], Some(50));
        let east = "east"
            .bytes()
            .fold(0u128, |h, b| h * 31 + u128::from(b) % 7 + 1);
        let giver = life(
            &dir,
            "west",
            &[
                &format!("owner + {e} 1 own"),
                &format!("owner - {e} 60 {east:032x}"),
                &format!("owner + {e} 80 adopted"),
            ],
            None,
        );
        let found = check(&[dead.clone(), giver.clone()], 100).expect("check");
        assert!(found.holds(), "{found:?}");
        assert_eq!(found.awaiting_adoption, 19);
        // Handed to a pod alive all along: the gap is a loss.
        let alive = life(&dir, "east", &[], None);
        let found = check(&[alive, giver], 100).expect("check");
        assert_eq!(found.unowned, 19, "{found:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_hand_off_across_a_stop_awaits_its_adoption_and_without_the_stop_it_is_a_loss() {
        let dir = dir("stall");
        let e = id(13);
        let cluster = |name: &str| {
            name.bytes()
                .fold(0u128, |h, b| h * 31 + u128::from(b) % 7 + 1)
        };
        let (west, east) = (cluster("west"), cluster("east"));
        // West, stopped at tick 100 until 160, hands the body on at 130 as it catches up; east
        // took west for dead and adopted it at 162, and hands it back at 163.
        let mut giver = life(
            &dir,
            "west",
            &[
                &format!("owner + {e} 1 own"),
                &format!("owner - {e} 130 {east:032x}"),
                &format!("owner + {e} 164 taken"),
            ],
            None,
        );
        let adopter = life(
            &dir,
            "east",
            &[
                &format!("owner + {e} 162 adopted"),
                &format!("owner - {e} 163 {west:032x}"),
            ],
            None,
        );
        giver.stopped.push((100, 160));
        let found = check(&[giver.clone(), adopter.clone()], 200).expect("check");
        assert!(found.holds(), "{found:?}");
        assert_eq!(found.handed_across_a_stall, 31, "{found:?}");
        // No stop: the same gap is a loss.
        giver.stopped.clear();
        let found = check(&[giver, adopter.clone()], 200).expect("check");
        assert_eq!(found.unowned, 31, "{found:?}");
        // West hands it at 90 to east, stopped at 93 until 153 before reading it, and takes it
        // back at 125 when it takes east for dead.
        let giver = life(
            &dir,
            "west",
            &[
                &format!("owner + {e} 1 own"),
                &format!("owner - {e} 90 {east:032x}"),
                &format!("owner + {e} 125 adopted"),
            ],
            None,
        );
        let mut taker = life(&dir, "east", &[], None);
        taker.stopped.push((93, 153));
        let found = check(&[giver.clone(), taker], 200).expect("check");
        assert!(found.holds(), "{found:?}");
        assert_eq!(found.handed_across_a_stall, 34, "{found:?}");
        // Stopped long after the hand-off: the taker had time to take it.
        let mut late = life(&dir, "east", &[], None);
        late.stopped.push((110, 170));
        let found = check(&[giver, late], 200).expect("check");
        assert_eq!(found.unowned, 34, "{found:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_stalled_pods_copy_beside_the_one_taken_back_is_across_a_stall() {
        let dir = dir("returned");
        let e = id(17);
        let east = "east"
            .bytes()
            .fold(0u128, |h, b| h * 31 + u128::from(b) % 7 + 1);
        // West hands it to east at 20; east, stopped from 21 to 81, takes it (since 21) as it
        // wakes; west took it back at 82, east gives it up at 90.
        let giver = life(
            &dir,
            "west",
            &[
                &format!("owner + {e} 1 own"),
                &format!("owner - {e} 20 {east:032x}"),
                &format!("owner + {e} 82 adopted"),
            ],
            None,
        );
        let mut taker = life(
            &dir,
            "east",
            &[&format!("owner + {e} 21 taken"), &format!("owner - {e} 90")],
            None,
        );
        taker.stopped.push((21, 81));
        let found = check(&[giver, taker.clone()], 100).expect("check");
        assert!(found.holds(), "{found:?}");
        assert_eq!(found.across_a_stall, 9, "{found:?}");
        // Taken back as its own (not a return): two owners.
        let giver = life(
            &dir,
            "west",
            &[
                &format!("owner + {e} 1 own"),
                &format!("owner - {e} 20 {east:032x}"),
                &format!("owner + {e} 82 own"),
            ],
            None,
        );
        let found = check(&[giver, taker], 100).expect("check");
        assert_eq!(found.owned_twice, 9, "{found:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
