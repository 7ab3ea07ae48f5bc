//! A ledger of what became of each routed op and contact report, by name, as one cluster saw
//! it: the events of the stream that name one, each as a [`LedgerEntry`]
//! ([`LedgerEntry::from_event`]). The counters in [`ClusterStats`](super::ClusterStats) say
//! how many ops were applied, dropped or given up; the ledger says which. A harness that
//! keeps every pod's events of a run (`crate::Cluster::keep_events`) can follow each name from
//! its first send to its end, and tell an op applied twice, or lost, from two outcomes counted
//! for one op (`seam chaos` does).
//!
//! A name is its issuer and the issuer's number for it (ops and contact reports of one issuer
//! share the counter, so a name is one or the other). Events of a name, across clusters:
//!
//! - [`LedgerEvent::Sent`] by each cluster that took it into its hands to send: its issuer, and
//!   a former owner that took it on to forward;
//! - [`LedgerEvent::Answered`] by such a cluster when the receiver answered it done (the
//!   receiver applied it, dropped it for good, or took it on to forward);
//! - one end: [`LedgerEvent::Applied`] (an op applied by its target's owner, a report surfaced
//!   to its game code or merged with its own copy), [`LedgerEvent::Stale`] (dropped by a
//!   receiver as older than `max_op_age_ticks`), dropped for another reason by a receiver or
//!   the sender ([`LedgerEvent::Gone`]: its entity exists nowhere known;
//!   [`LedgerEvent::Invalid`]: invalid or beyond the bound; [`LedgerEvent::Overflow`]: out of
//!   the window, or no room in the queue) or [`LedgerEvent::GivenUp`] (by its sender:
//!   unanswered past answering, or for a report, nobody left to tell or the pair its own now);
//! - [`LedgerEvent::Unanswered`]: still in a sender's hands when it stopped
//!   (`crate::Cluster::unanswered_names`, written by the harness at the end).
//!
//! An op applied, or a contact report taken, on a body this cluster adopted from a neighbour
//! taken for dead says so ([`LedgerEntry::adopted_from`]): when that neighbour was only
//! stalled, it keeps its own copy of the body and applies the op (or surfaces the report)
//! there too (from its buffer, on waking), and the adopter's
//! copy stops when the neighbour is heard again — two applications, one to a copy that is
//! dropped. Only an application to a copy that lives on counts.

use seam_sim::wire::ClusterId;

use super::event::{ClusterEvent, Name, OpDrop};

/// What a name stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Carried {
    /// A routed op (a write on a remote-owned entity).
    Op,
    /// A contact report.
    Contact,
}

/// Something that happened to a name at one cluster (see the module's text).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LedgerEvent {
    /// Taken into this cluster's hands to send: issued here, or taken on to forward.
    Sent,
    /// Answered done by the cluster this one sent it to.
    Answered,
    /// Applied here (an op on an entity owned here), or surfaced or merged here (a report).
    Applied,
    /// Dropped here as older than `max_op_age_ticks`.
    Stale,
    /// Dropped here: its entity exists nowhere this cluster or its receiver knows of.
    Gone,
    /// Dropped here: invalid values, or values beyond the bound.
    Invalid,
    /// Dropped here: numbered out of the window, or no room in the queue for its owner.
    Overflow,
    /// Given up by this cluster, its sender.
    GivenUp,
    /// Still unanswered here when this cluster stopped.
    Unanswered,
}

impl LedgerEvent {
    /// Every event, in the order of their codes.
    pub const ALL: [LedgerEvent; 9] = [
        LedgerEvent::Sent,
        LedgerEvent::Answered,
        LedgerEvent::Applied,
        LedgerEvent::Stale,
        LedgerEvent::Gone,
        LedgerEvent::Invalid,
        LedgerEvent::Overflow,
        LedgerEvent::GivenUp,
        LedgerEvent::Unanswered,
    ];

    /// Whether it ends the name: applied, or dropped or given up for good.
    pub fn ends(self) -> bool {
        matches!(
            self,
            LedgerEvent::Applied
                | LedgerEvent::Stale
                | LedgerEvent::Gone
                | LedgerEvent::Invalid
                | LedgerEvent::Overflow
                | LedgerEvent::GivenUp
        )
    }

    /// A short word for it (what [`LedgerEntry::line`] writes).
    pub fn word(self) -> &'static str {
        match self {
            LedgerEvent::Sent => "sent",
            LedgerEvent::Answered => "answered",
            LedgerEvent::Applied => "applied",
            LedgerEvent::Stale => "stale",
            LedgerEvent::Gone => "gone",
            LedgerEvent::Invalid => "invalid",
            LedgerEvent::Overflow => "overflow",
            LedgerEvent::GivenUp => "given-up",
            LedgerEvent::Unanswered => "unanswered",
        }
    }
}

/// One event of one name at one cluster.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LedgerEntry {
    /// The cluster's tick when it happened.
    pub tick: u64,
    /// The name's issuer.
    pub issuer: ClusterId,
    /// The issuer's number for it.
    pub seq: u64,
    /// Op or contact report.
    pub carried: Carried,
    /// What happened.
    pub event: LedgerEvent,
    /// For an op applied here, or dropped as stale by its sender on finding its target its own
    /// now, or a contact report taken here on a body held for another: the cluster the body
    /// was adopted from, if this cluster holds it as an adopter
    /// (the owner taken for dead).
    pub adopted_from: Option<ClusterId>,
}

impl LedgerEntry {
    /// The entry for `event`, kept at `tick`, if it names an op or a contact report and is
    /// one of a name's steps (see the module docs).
    pub fn from_event(tick: u64, event: &ClusterEvent) -> Option<LedgerEntry> {
        use ClusterEvent as E;
        let (name, carried, event, adopted_from): (Name, _, _, _) = match *event {
            E::OpSent { name, .. } => (name, Carried::Op, LedgerEvent::Sent, None),
            E::OpAnswered { name } => (name, Carried::Op, LedgerEvent::Answered, None),
            E::OpApplied {
                name, adopted_from, ..
            } => (name, Carried::Op, LedgerEvent::Applied, adopted_from),
            E::OpDropped {
                name,
                reason,
                adopted_from,
            } => {
                let event = match reason {
                    OpDrop::Stale => LedgerEvent::Stale,
                    OpDrop::Expired => LedgerEvent::GivenUp,
                    OpDrop::Gone => LedgerEvent::Gone,
                    OpDrop::Invalid | OpDrop::Absurd => LedgerEvent::Invalid,
                    OpDrop::Window | OpDrop::QueueFull => LedgerEvent::Overflow,
                };
                (name, Carried::Op, event, adopted_from)
            }
            E::ContactReported { name } => (name, Carried::Contact, LedgerEvent::Sent, None),
            E::ContactAnswered { name } => (name, Carried::Contact, LedgerEvent::Answered, None),
            E::ContactDelivered { name, adopted_from } => {
                (name, Carried::Contact, LedgerEvent::Applied, adopted_from)
            }
            E::ContactStale { name } => (name, Carried::Contact, LedgerEvent::Stale, None),
            E::ContactGivenUp { name, .. } => (name, Carried::Contact, LedgerEvent::GivenUp, None),
            _ => return None,
        };
        Some(LedgerEntry {
            tick,
            issuer: name.issuer,
            seq: name.seq,
            carried,
            event,
            adopted_from,
        })
    }

    /// The entry as one line of text (no newline): `tick event op|contact issuer seq`, then
    /// `adopted-from` if there is one; clusters as 32 hex digits.
    pub fn line(&self) -> String {
        let carried = match self.carried {
            Carried::Op => "op",
            Carried::Contact => "contact",
        };
        let mut line = format!(
            "{} {} {carried} {:032x} {}",
            self.tick,
            self.event.word(),
            self.issuer.as_u128(),
            self.seq
        );
        if let Some(from) = self.adopted_from {
            line += &format!(" {:032x}", from.as_u128());
        }
        line
    }

    /// Reads a line written by [`LedgerEntry::line`]; `None` if it is not one (a pod killed
    /// mid-write leaves a line cut short).
    pub fn parse(line: &str) -> Option<LedgerEntry> {
        let mut words = line.split(' ');
        let tick = words.next()?.parse().ok()?;
        let word = words.next()?;
        let event = LedgerEvent::ALL.into_iter().find(|e| e.word() == word)?;
        let carried = match words.next()? {
            "op" => Carried::Op,
            "contact" => Carried::Contact,
            _ => return None,
        };
        let issuer = parse_cluster(words.next()?)?;
        let seq = words.next()?.parse().ok()?;
        let adopted_from = match words.next() {
            Some(word) => Some(parse_cluster(word)?),
            None => None,
        };
        if words.next().is_some() {
            return None;
        }
        Some(LedgerEntry {
            tick,
            issuer,
            seq,
            carried,
            event,
            adopted_from,
        })
    }
}

/// A cluster id written as 32 hex digits.
pub fn parse_cluster(word: &str) -> Option<ClusterId> {
    if word.len() != 32 {
        return None;
    }
    u128::from_str_radix(word, 16)
        .ok()
        .map(ClusterId::from_u128)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_read_back_as_written_and_cut_lines_are_refused() {
        let issuer = ClusterId::named("run", "west");
        let adopted = [None, Some(ClusterId::named("run", "east"))];
        for (event, adopted_from) in LedgerEvent::ALL.into_iter().zip(adopted.iter().cycle()) {
            for carried in [Carried::Op, Carried::Contact] {
                let entry = LedgerEntry {
                    tick: 1_234,
                    issuer,
                    seq: 1_733_000_000_000_123,
                    carried,
                    event,
                    adopted_from: *adopted_from,
                };
                let line = entry.line();
                assert_eq!(LedgerEntry::parse(&line), Some(entry), "{line}");
                for cut in 0..line.len() - 1 {
                    let short = &line[..cut];
                    // A cut inside the number may still read as a smaller number (readers
                    // take only lines ended by a newline); a cut anywhere else is refused.
                    if let Some(read) = LedgerEntry::parse(short) {
                        assert!(
                            read.seq < entry.seq || read.adopted_from.is_none(),
                            "{short}"
                        );
                    }
                }
            }
        }
        assert_eq!(LedgerEntry::parse("12 applied op 00 7"), None);
        assert_eq!(LedgerEntry::parse(""), None);
    }
}
