//! Pods' ledgers (`seam node --ledger FILE`, see `seam_proxy::LedgerEntry`): what became of
//! every routed op and contact report, by name, written by each pod as it ticks; and
//! [`follow`], which reads the ledgers of every life of every pod of a run and follows each
//! name from its first send to its end.
//!
//! The counters the pods report say how many ops were routed and how many ended each way; one
//! op counted twice (applied by an owner that was killed before its answer went out, and then
//! given up by its sender) hides one lost in the sums. Followed by name, nothing hides: an op
//! applied twice, one that ended twice, and one with no end are each seen and counted.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use seam_proxy::{Carried, LedgerEntry, LedgerEvent, parse_cluster};
use seam_sim::wire::ClusterId;
use serde::Serialize;

/// A pod's ledger file, written as it ticks.
pub struct LedgerFile {
    out: BufWriter<File>,
}

/// How a ledger file starts: the cluster whose ledger it is.
pub(crate) const HEADER: &str = "# cluster ";

/// How an owner line starts (written and read by [`crate::owners`]; [`follow`] skips them).
pub const OWNER_PREFIX: &str = "owner ";

impl LedgerFile {
    /// Creates (or truncates) `path`, the ledger of `cluster`.
    pub fn create(path: &Path, cluster: ClusterId) -> io::Result<Self> {
        let mut out = BufWriter::new(File::create(path)?);
        writeln!(out, "{HEADER}{:032x}", cluster.as_u128())?;
        out.flush()?;
        Ok(Self { out })
    }

    /// Writes `lines` (owner lines, see `crate::owners`) and hands them to the kernel.
    pub fn write_lines(&mut self, lines: &[String]) -> io::Result<()> {
        if lines.is_empty() {
            return Ok(());
        }
        for line in lines {
            writeln!(self.out, "{line}")?;
        }
        self.out.flush()
    }

    /// Writes `entries`, a line each, and hands them to the kernel: a pod killed after this
    /// call leaves them in the file.
    pub fn write(&mut self, entries: &[LedgerEntry]) -> io::Result<()> {
        if entries.is_empty() {
            return Ok(());
        }
        for entry in entries {
            writeln!(self.out, "{}", entry.line())?;
        }
        self.out.flush()
    }
}

/// One life of a pod: the ledger it wrote, and whether it was killed (so what it still held
/// went with it).
#[derive(Debug, Clone)]
pub struct Life {
    /// Its ledger file.
    pub path: PathBuf,
    /// Killed (not stopped at the end of the run), after the last tick it was seen to finish.
    pub killed_after: Option<u64>,
    /// The world ticks it was stopped from and continued at, each stop of it (`u64::MAX` for
    /// one not yet over).
    pub stopped: Vec<(u64, u64)>,
}

impl Life {
    /// Whether it was killed.
    pub fn killed(&self) -> bool {
        self.killed_after.is_some()
    }

    /// Whether it was still ticking at world tick `tick` (pods of a run share the tick count).
    fn ticking_at(&self, tick: u64) -> bool {
        self.killed_after.is_none_or(|last| last >= tick)
    }
}

/// What became of the names of one kind (ops, or contact reports), followed across every
/// pod's ledgers. Every name a life sent lands in exactly one of the counts from `ended_once`
/// to `lost`.
#[derive(Debug, Clone, Default, Serialize)]
pub struct NameCounts {
    /// Names some life sent.
    pub sent: u64,
    /// Ended once: applied once, or dropped or given up once.
    pub ended_once: u64,
    /// Those ended once, by their end (`applied`, `stale`, `gone`, `invalid`, `overflow`,
    /// `given-up`: the words of `seam_proxy::LedgerEvent`).
    pub ended_by: BTreeMap<String, u64>,
    /// Applied by two owners, or twice by one: the failure delivery exists to prevent.
    pub applied_twice: u64,
    /// Of those ended once: applied also to an adopter's copy of a body whose owner was only
    /// stalled, applied it on waking and kept its own copy (the adopter's stopped).
    pub applied_to_dropped_copy: u64,
    /// Ended twice without being applied twice (applied at one cluster and given up at its
    /// sender, say), by the two ends.
    pub ended_twice: BTreeMap<String, u64>,
    /// No end logged, but every cluster that sent it had it answered done: its receiver's
    /// ledger lost the end (a pod killed between publishing the answer and writing its
    /// ledger).
    pub answered_end_unlogged: u64,
    /// No end: still unanswered when its sender stopped at the end of the run.
    pub unanswered_at_end: u64,
    /// No end: unanswered in the hands of a life that was killed.
    pub with_killed_sender: u64,
    /// No end, and held by no life that stopped or was killed with it: lost.
    pub lost: u64,
    /// A few lost or applied-twice names with their events, to start tracing from.
    pub examples: Vec<String>,
    /// Names with an end but no life's send logged (sent in the tick its issuer was killed,
    /// before the ledger was written); not in `sent`.
    pub ended_unsent: u64,
}

impl NameCounts {
    /// Names that ended twice, by any two ends.
    pub fn ended_twice_total(&self) -> u64 {
        self.ended_twice.values().sum()
    }

    /// Names ended once by `event`.
    pub fn ended_as(&self, event: LedgerEvent) -> u64 {
        self.ended_by.get(event.word()).copied().unwrap_or(0)
    }

    /// Names with two ends: applied twice, or two ends of other kinds.
    pub fn ended_twice_all(&self) -> u64 {
        self.applied_twice + self.ended_twice_total()
    }

    /// Whether every name was delivered as promised: none lost, none applied twice.
    pub fn holds(&self) -> bool {
        self.lost == 0 && self.applied_twice == 0
    }
}

/// What [`follow`] found.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Followed {
    /// Routed ops.
    pub ops: NameCounts,
    /// Contact reports.
    pub contacts: NameCounts,
    /// Lines that were not ledger entries (a life killed mid-line leaves one).
    pub unreadable_lines: u64,
}

/// At most this many example names are kept per kind.
const EXAMPLES: usize = 5;

/// Reads the ledgers of `lives` and follows every name to its end. A missing file (a life
/// killed before it wrote a line) is no names.
pub fn follow(lives: &[Life]) -> io::Result<Followed> {
    let mut followed = Followed::default();
    let (names, cluster_of) = read(lives, &mut followed.unreadable_lines)?;
    for ((carried, issuer, seq), events) in names {
        let counts = match carried {
            Carried::Op => &mut followed.ops,
            Carried::Contact => &mut followed.contacts,
        };
        let name = NameEvents {
            issuer,
            seq,
            events: &events,
            lives,
            cluster_of: &cluster_of,
        };
        name.count_into(counts);
    }
    Ok(followed)
}

/// A name: its issuer and number.
type Name = (Carried, u128, u64);

/// Each name's events, with the life that logged each.
type NamesEvents = HashMap<Name, Vec<(usize, LedgerEntry)>>;

/// Every life's ledger read: each name's events with the life that logged them, and whose
/// ledger each life's is (from its first line). Lines that are not entries are counted in
/// `unreadable`.
fn read(lives: &[Life], unreadable: &mut u64) -> io::Result<(NamesEvents, Vec<Option<ClusterId>>)> {
    let mut names = NamesEvents::new();
    let mut cluster_of: Vec<Option<ClusterId>> = vec![None; lives.len()];
    for (index, life) in lives.iter().enumerate() {
        let text = match std::fs::read_to_string(&life.path) {
            Ok(text) => text,
            Err(e) if e.kind() == io::ErrorKind::NotFound => continue,
            Err(e) => return Err(e),
        };
        // Only whole lines: what follows the last newline was cut short by a kill.
        let whole = text.rfind('\n').map_or("", |end| &text[..end]);
        for line in whole.lines() {
            if let Some(cluster) = line.strip_prefix(HEADER) {
                cluster_of[index] = parse_cluster(cluster);
                continue;
            }
            if line.starts_with(OWNER_PREFIX) {
                continue;
            }
            match LedgerEntry::parse(line) {
                Some(e) => names
                    .entry((e.carried, e.issuer.as_u128(), e.seq))
                    .or_default()
                    .push((index, e)),
                None => *unreadable += 1,
            }
        }
    }
    Ok((names, cluster_of))
}

/// One name's events across the run's lives, to be counted.
struct NameEvents<'a> {
    issuer: u128,
    seq: u64,
    events: &'a [(usize, LedgerEntry)],
    lives: &'a [Life],
    cluster_of: &'a [Option<ClusterId>],
}

impl NameEvents<'_> {
    /// Counts the name where its events put it.
    fn count_into(&self, counts: &mut NameCounts) {
        let events = self.events;
        let dropped_copies = events.iter().filter(|e| self.to_dropped_copy(e)).count();
        let ends: Vec<&LedgerEntry> = events
            .iter()
            .filter(|e| !self.to_dropped_copy(e))
            .map(|(_, e)| e)
            .filter(|e| e.event.ends())
            .collect();
        let senders: Vec<usize> = events
            .iter()
            .filter(|&&(_, e)| e.event == LedgerEvent::Sent)
            .map(|&(life, _)| life)
            .collect();
        if senders.is_empty() {
            counts.ended_unsent += u64::from(!ends.is_empty());
            return;
        }
        counts.sent += 1;
        let applied = ends
            .iter()
            .filter(|e| e.event == LedgerEvent::Applied)
            .count();
        if applied >= 2 {
            counts.applied_twice += 1;
            if counts.examples.len() < EXAMPLES {
                counts.examples.push(self.example());
            }
            return;
        }
        match ends.len() {
            0 => self.count_unended(&senders, counts),
            1 => {
                counts.ended_once += 1;
                *counts
                    .ended_by
                    .entry(ends[0].event.word().into())
                    .or_default() += 1;
                counts.applied_to_dropped_copy += u64::from(dropped_copies > 0);
            }
            _ => {
                let mut words: Vec<String> = ends
                    .iter()
                    .map(|e| match e.adopted_from {
                        Some(_) => format!("{} by an adopter", e.event.word()),
                        None => e.event.word().to_owned(),
                    })
                    .collect();
                words.sort_unstable();
                *counts.ended_twice.entry(words.join(" + ")).or_default() += 1;
            }
        }
    }

    /// Whether `entry` is an application to an adopter's copy of a body whose owner also
    /// applied it in a life still ticking after the adopter's application: the owner was
    /// only stalled, applied it on waking, was heard again and kept its copy, and the
    /// adopter's copy stopped (see `seam_proxy::LedgerEntry::adopted_from`). An owner killed
    /// first was taken for dead for want of frames, so it stopped ticking before the adopter
    /// took its bodies: the adopter's copy lives on, and two applications are two.
    fn to_dropped_copy(&self, &(_, e): &(usize, LedgerEntry)) -> bool {
        let owner_applied_and_ticked_on = |from: ClusterId, adopter_tick: u64| {
            self.events.iter().any(|&(life, e)| {
                e.event == LedgerEvent::Applied
                    && e.adopted_from.is_none()
                    && self.cluster_of[life] == Some(from)
                    && self.lives[life].ticking_at(adopter_tick)
            })
        };
        e.event == LedgerEvent::Applied
            && e.adopted_from
                .is_some_and(|from| owner_applied_and_ticked_on(from, e.tick))
    }

    /// Counts a name sent by `senders` with no end: where it was when the run ended.
    fn count_unended(&self, senders: &[usize], counts: &mut NameCounts) {
        let has = |life: usize, event: LedgerEvent| {
            (self.events.iter()).any(|&(l, e)| l == life && e.event == event)
        };
        let holding: Vec<usize> = senders
            .iter()
            .copied()
            .filter(|&life| !has(life, LedgerEvent::Answered))
            .collect();
        // Each life still holding it must account for it: killed with it, or stopped with it
        // unanswered. A life that ran to the end and says neither dropped it unsaid.
        let accounted =
            |&life: &usize| self.lives[life].killed() || has(life, LedgerEvent::Unanswered);
        if holding.is_empty() {
            counts.answered_end_unlogged += 1;
        } else if !holding.iter().all(accounted) {
            counts.lost += 1;
            if counts.examples.len() < EXAMPLES {
                counts.examples.push(self.example());
            }
        } else if holding
            .iter()
            .any(|&life| has(life, LedgerEvent::Unanswered))
        {
            counts.unanswered_at_end += 1;
        } else {
            counts.with_killed_sender += 1;
        }
    }

    /// The name and its events, to start tracing from.
    fn example(&self) -> String {
        let events: Vec<String> = (self.events.iter())
            .map(|&(life, e)| {
                let copy = if e.adopted_from.is_some() {
                    " to an adopted copy"
                } else {
                    ""
                };
                format!(
                    "{}{copy} at tick {} by {}",
                    e.event.word(),
                    e.tick,
                    self.lives[life].path.display()
                )
            })
            .collect();
        format!("{:032x}#{}: {}", self.issuer, self.seq, events.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(seq: u64, carried: Carried, event: LedgerEvent) -> LedgerEntry {
        LedgerEntry {
            tick: 7,
            issuer: ClusterId::named("t", "west"),
            seq,
            carried,
            event,
            adopted_from: None,
        }
    }

    /// Op `seq` applied to a body adopted from `from`.
    fn applied_adopted(seq: u64, from: &str) -> LedgerEntry {
        LedgerEntry {
            adopted_from: Some(ClusterId::named("t", from)),
            ..entry(seq, Carried::Op, LedgerEvent::Applied)
        }
    }

    /// Writes the ledger of `cluster`'s life `name`, then `tail` as it is.
    fn write(dir: &Path, name: &str, entries: &[LedgerEntry], tail: &str) -> PathBuf {
        let path = dir.join(name);
        let cluster = ClusterId::named("t", name.split('-').next().unwrap_or(name));
        let mut file = LedgerFile::create(&path, cluster).expect("the test's ledger files");
        file.write(entries).expect("the test's ledger files");
        drop(file);
        std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .expect("the test's ledger files")
            .write_all(tail.as_bytes())
            .expect("the test's ledger files");
        path
    }

    /// Every way a name can end is told apart: each name below is built to land in one count,
    /// and a count that takes the wrong names fails.
    #[test]
    fn every_name_lands_in_the_count_its_events_make() {
        use Carried::{Contact, Op};
        use LedgerEvent::*;
        let dir = std::env::temp_dir().join(format!("seam-ledger-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("the test's ledger files");
        // The issuer's life, stopped at the end.
        let issuer = write(
            &dir,
            "west-0",
            &[
                entry(1, Op, Sent),
                entry(1, Op, Answered),
                entry(2, Op, Sent),
                entry(2, Op, Answered),
                entry(3, Op, Sent),
                entry(3, Op, GivenUp),
                entry(4, Op, Sent),
                entry(5, Op, Sent),
                entry(5, Op, Unanswered),
                entry(6, Op, Sent),
                entry(6, Op, Answered),
                entry(7, Contact, Sent),
                entry(7, Contact, Answered),
                entry(8, Contact, Sent),
                entry(9, Op, Sent),
                entry(9, Op, Answered),
                entry(11, Op, Sent),
                entry(11, Op, Answered),
                entry(12, Op, Sent),
                entry(12, Op, Answered),
                entry(13, Op, Sent),
                entry(13, Op, Answered),
                entry(14, Contact, Sent),
                entry(14, Contact, Answered),
            ],
            // A line cut short by a kill: not read.
            "7 applied op 0000",
        );
        // Its owner's first life, killed: applied 1, 2 and 3, and 9 before the kill.
        let owner_killed = write(
            &dir,
            "east-0",
            &[
                entry(1, Op, Applied),
                entry(2, Op, Applied),
                entry(3, Op, Applied),
                entry(7, Contact, Applied),
                entry(10, Op, Applied),
                entry(12, Op, Applied),
            ],
            "",
        );
        // The owner's next life applied 2 again; forwarder life took 9 on and was killed
        // holding it.
        let owner = write(
            &dir,
            "east-1",
            &[
                entry(2, Op, Applied),
                entry(11, Op, Applied),
                entry(13, Op, Applied),
                entry(14, Contact, Applied),
            ],
            "",
        );
        let forwarder = write(&dir, "north-0", &[entry(9, Op, Sent)], "");
        // An adopter of east's bodies applied 11 and surfaced contact 14, which east's next
        // life applied too and ticked on after (east was stalled: the adopter's copy was
        // dropped), and 12, which east's
        // first life applied before it was killed (the adopter's copy lives on: applied
        // twice).
        let adopter = write(
            &dir,
            "south-0",
            &[
                applied_adopted(11, "east"),
                applied_adopted(12, "east"),
                LedgerEntry {
                    event: Stale,
                    ..applied_adopted(13, "east")
                },
                LedgerEntry {
                    carried: Contact,
                    ..applied_adopted(14, "east")
                },
            ],
            "",
        );
        let life = |path: &PathBuf, killed_after| Life {
            path: path.clone(),
            killed_after,
            stopped: Vec::new(),
        };
        let lives = [
            life(&issuer, None),
            // Killed after tick 6: before the adopter applied 12 at tick 7.
            life(&owner_killed, Some(6)),
            // Killed later: it ticked on past the adopter's application of 11.
            life(&owner, Some(7)),
            life(&forwarder, Some(0)),
            life(&adopter, None),
            life(&dir.join("never-written"), Some(0)),
        ];
        let followed = follow(&lives).expect("the test's ledger files");
        let ops = &followed.ops;
        // 1 applied once; 2 applied twice; 3 applied and given up; 4 lost; 5 unanswered at
        // the end; 6 answered with its end unlogged; 9 answered by the forwarder, which was
        // killed holding it; 10 has no send; 11 applied once to a copy that lives on; 12
        // applied twice; 13 applied by east and dropped as stale by the adopter.
        assert_eq!(ops.sent, 10);
        assert_eq!(ops.ended_once, 2);
        assert_eq!(ops.ended_by, BTreeMap::from([("applied".to_owned(), 2)]));
        assert_eq!(ops.ended_as(Applied), 2);
        assert_eq!(ops.applied_to_dropped_copy, 1);
        assert_eq!(ops.applied_twice, 2);
        assert_eq!(
            ops.ended_twice,
            BTreeMap::from([
                ("applied + given-up".to_owned(), 1),
                ("applied + stale by an adopter".to_owned(), 1)
            ])
        );
        assert_eq!(ops.lost, 1);
        assert_eq!(ops.unanswered_at_end, 1);
        assert_eq!(ops.answered_end_unlogged, 1);
        assert_eq!(ops.with_killed_sender, 1);
        assert_eq!(ops.ended_unsent, 1);
        assert_eq!(ops.examples.len(), 3, "{:?}", ops.examples);
        // The counts add up: every name sent is in exactly one.
        assert_eq!(
            ops.sent,
            ops.ended_once
                + ops.ended_twice_all()
                + ops.answered_end_unlogged
                + ops.unanswered_at_end
                + ops.with_killed_sender
                + ops.lost
        );
        assert!(!ops.holds());
        // Contact 7 surfaced once; 8 lost; 14 surfaced by east, which ticked on, and by the
        // adopter of the body east was stalled with (a copy dropped since).
        assert_eq!(followed.contacts.sent, 3);
        assert_eq!(followed.contacts.ended_once, 2);
        assert_eq!(followed.contacts.applied_to_dropped_copy, 1);
        assert_eq!(followed.contacts.applied_twice, 0);
        assert_eq!(followed.contacts.lost, 1);
        assert_eq!(followed.unreadable_lines, 0);
        std::fs::remove_dir_all(&dir).expect("the test's ledger files");
    }
}
