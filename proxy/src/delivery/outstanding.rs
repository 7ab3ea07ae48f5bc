//! The sender's side: what this cluster has sent and not had answered ([`Outstanding`]).
//!
//! A sender keeps each item it sends (an op issued here or taken on to forward, a contact
//! report) until the receiver answers it in an events frame ([`seam_sim::wire::OpAck`]), and
//! sends it again every `op_retry_ticks` to the cluster it then knows to be the right one
//! (see `super::Outbound`).

use seam_sim::wire::{ClusterId, ContactReport, IdMap, RoutedOp};

use crate::events::Name;

/// Ops a sender keeps unanswered per destination; more are dropped, counted.
pub(crate) const MAX_UNANSWERED: usize = 4096;

/// What a sender keeps until it is answered: a routed op or a contact report.
pub(crate) trait Numbered: Copy {
    /// Its name, sent by cluster `me` (a forwarded op keeps its issuer's).
    fn name(&self, me: ClusterId) -> Name;
    /// Its age when sent.
    fn age_ticks(&self) -> u32;
    /// What is sent again for it, named `name`, at `age` (cluster `me` sending).
    fn resent(&self, me: ClusterId, name: Name, age: u64) -> Self;
}

impl Numbered for RoutedOp {
    fn name(&self, me: ClusterId) -> Name {
        Name::new(self.issuer.unwrap_or(me), self.seq)
    }

    fn age_ticks(&self) -> u32 {
        self.age_ticks
    }

    fn resent(&self, me: ClusterId, name: Name, age: u64) -> Self {
        RoutedOp {
            issuer: (name.issuer != me).then_some(name.issuer),
            age_ticks: u32::try_from(age).unwrap_or(u32::MAX),
            ..*self
        }
    }
}

impl Numbered for ContactReport {
    fn name(&self, me: ClusterId) -> Name {
        Name::new(me, self.seq)
    }

    fn age_ticks(&self) -> u32 {
        self.age_ticks
    }

    fn resent(&self, _me: ClusterId, _name: Name, age: u64) -> Self {
        ContactReport {
            age_ticks: u32::try_from(age).unwrap_or(u32::MAX),
            ..*self
        }
    }
}

/// What [`Outstanding::keep_sent`] made of a frame's items.
pub(crate) struct Kept<T> {
    /// The items to send: those kept now or before.
    pub(crate) send: Vec<T>,
    /// Names sent for the first time and kept.
    pub(crate) new: Vec<Name>,
    /// Names sent for the first time with no room to keep them: not sent, given up.
    pub(crate) refused: Vec<Name>,
}

/// An op (or contact report) sent and not answered yet.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Unanswered<T> {
    /// What was sent, as first sent (an op's issuer filled in: this cluster or the one it
    /// forwards for).
    pub(crate) sent: T,
    /// The cluster it was last sent to (or meant for, if that one was gone).
    pub(crate) to: ClusterId,
    /// This cluster's tick the op's age counts from: its tick when the op came into its hands,
    /// less the age it had then.
    pub(crate) born_tick: i64,
    /// This cluster's tick at which to send it again.
    pub(crate) due_tick: u64,
    /// Answered "not here" by the cluster it was last sent to.
    pub(crate) returned: bool,
}

impl<T> Unanswered<T> {
    /// Its age at this cluster's `tick`.
    pub(crate) fn age(&self, tick: u64) -> u64 {
        (tick as i64 - self.born_tick).max(0) as u64
    }
}

/// The ops (or contact reports) this cluster has sent and not had answered, by name.
#[derive(Debug)]
pub(crate) struct Outstanding<T> {
    ops: IdMap<Name, Unanswered<T>>,
    per_destination: IdMap<ClusterId, usize>,
}

impl<T> Default for Outstanding<T> {
    fn default() -> Self {
        Self {
            ops: IdMap::default(),
            per_destination: IdMap::default(),
        }
    }
}

impl<T: Copy> Outstanding<T> {
    /// How many there are.
    pub(crate) fn len(&self) -> usize {
        self.ops.len()
    }

    /// Whether `key` is kept.
    pub(crate) fn contains(&self, key: Name) -> bool {
        self.ops.contains_key(&key)
    }

    /// Keeps an op just sent (or meant) for `op.to`; `false` when that destination already has
    /// [`MAX_UNANSWERED`] (the op is not kept: the caller counts it dropped).
    pub(crate) fn keep(&mut self, key: Name, op: Unanswered<T>) -> bool {
        if let Some(old) = self.ops.get_mut(&key) {
            let was = old.to;
            *old = op;
            self.moved(was, op.to);
            return true;
        }
        let count = self.per_destination.entry(op.to).or_default();
        if *count >= MAX_UNANSWERED {
            return false;
        }
        *count += 1;
        self.ops.insert(key, op);
        true
    }

    fn moved(&mut self, from: ClusterId, to: ClusterId) {
        if from != to {
            self.forget_one(from);
            *self.per_destination.entry(to).or_default() += 1;
        }
    }

    fn forget_one(&mut self, to: ClusterId) {
        if let Some(count) = self.per_destination.get_mut(&to) {
            *count = count.saturating_sub(1);
        }
    }

    /// Takes `key` out (answered, or given up); `None` if it was not kept.
    pub(crate) fn take(&mut self, key: Name) -> Option<Unanswered<T>> {
        let op = self.ops.swap_remove(&key)?;
        self.forget_one(op.to);
        Some(op)
    }

    /// Makes `key` due at `tick` at the latest; `false` if it is not kept.
    pub(crate) fn due_at(&mut self, key: Name, tick: u64) -> bool {
        match self.ops.get_mut(&key) {
            Some(op) => {
                op.due_tick = op.due_tick.min(tick);
                true
            }
            None => false,
        }
    }

    /// Notes that the receiver answered `key` "not here", and makes it due at `tick`.
    pub(crate) fn returned(&mut self, key: Name, tick: u64) {
        if let Some(op) = self.ops.get_mut(&key) {
            op.returned = true;
            op.due_tick = op.due_tick.min(tick);
        }
    }

    /// Keeps the items of a frame that cluster `me` sends to `to` at `tick` until they are
    /// answered, due again `retry` ticks on: those sent for the first time are added (if the
    /// queue for `to` has room); resends are kept already.
    pub(crate) fn keep_sent(
        &mut self,
        me: ClusterId,
        to: ClusterId,
        items: Vec<T>,
        tick: u64,
        retry: u64,
    ) -> Kept<T>
    where
        T: Numbered,
    {
        let mut kept = Kept {
            send: Vec::with_capacity(items.len()),
            new: Vec::new(),
            refused: Vec::new(),
        };
        for item in items {
            let key = item.name(me);
            if self.contains(key) {
                kept.send.push(item);
                continue;
            }
            let pending = Unanswered {
                sent: item,
                to,
                born_tick: tick as i64 - i64::from(item.age_ticks()),
                due_tick: tick + retry,
                returned: false,
            };
            if self.keep(key, pending) {
                kept.send.push(item);
                kept.new.push(key);
            } else {
                kept.refused.push(key);
            }
        }
        kept
    }

    /// The names of the ops kept.
    pub(crate) fn names(&self) -> impl Iterator<Item = Name> + '_ {
        self.ops.keys().copied()
    }

    /// Takes the ops due at `tick` (to be sent again or given up).
    pub(crate) fn take_due(&mut self, tick: u64) -> Vec<(Name, Unanswered<T>)> {
        let due: Vec<Name> = self
            .ops
            .iter()
            .filter(|(_, op)| op.due_tick <= tick)
            .map(|(&key, _)| key)
            .collect();
        due.into_iter()
            .filter_map(|key| self.take(key).map(|op| (key, op)))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn issuer() -> ClusterId {
        ClusterId::from_u128(1)
    }

    fn unanswered(to: u128, due_tick: u64) -> Unanswered<RoutedOp> {
        Unanswered {
            sent: RoutedOp {
                op: seam_sim::wire::PhysicsOp::Wake {
                    target: seam_sim::wire::EntityId::from_u128(9),
                },
                seq: 0,
                issuer: None,
                issued_ns: 0,
                issued_tick: 0,
                age_ticks: 0,
            },
            to: ClusterId::from_u128(to),
            born_tick: 0,
            due_tick,
            returned: false,
        }
    }

    #[test]
    fn outstanding_ops_are_bounded_per_destination_and_taken_when_due() {
        let mut outstanding = Outstanding::default();
        for seq in 0..MAX_UNANSWERED as u64 {
            assert!(outstanding.keep(Name::new(issuer(), seq), unanswered(2, 10 + seq % 2)));
        }
        assert!(
            !outstanding.keep(Name::new(issuer(), u64::MAX), unanswered(2, 10)),
            "full for cluster 2"
        );
        assert!(outstanding.keep(Name::new(issuer(), u64::MAX), unanswered(3, 10)));
        // Moving one to cluster 3 makes room for cluster 2.
        assert!(outstanding.keep(Name::new(issuer(), 0), unanswered(3, 10)));
        assert!(outstanding.keep(Name::new(issuer(), u64::MAX - 1), unanswered(2, 10)));
        let due = outstanding.take_due(10);
        assert_eq!(due.len(), MAX_UNANSWERED / 2 + 2, "every op due at tick 10");
        assert!(due.iter().all(|(_, op)| op.due_tick <= 10));
        assert_eq!(outstanding.len(), MAX_UNANSWERED / 2);
        assert!(outstanding.due_at(Name::new(issuer(), 1), 10));
        outstanding.returned(Name::new(issuer(), 3), 10);
        let due = outstanding.take_due(10);
        assert_eq!(due.len(), 2);
        assert!(due.iter().any(|(key, op)| key.seq == 3 && op.returned));
        assert!(outstanding.take(Name::new(issuer(), 1)).is_none());
    }

    #[test]
    fn a_frame_keeps_what_it_sends_first_and_refuses_what_has_no_room() {
        let me = issuer();
        let to = ClusterId::from_u128(2);
        let op = |seq| RoutedOp {
            op: seam_sim::wire::PhysicsOp::Impulse {
                target: seam_sim::wire::EntityId::from_u128(9),
                impulse: [1.0, 0.0, 0.0],
            },
            seq,
            issuer: None,
            issued_ns: 0,
            issued_tick: 0,
            age_ticks: 4,
        };
        let mut outstanding = Outstanding::default();
        let kept = outstanding.keep_sent(me, to, vec![op(1), op(2)], 100, 10);
        assert_eq!(kept.send.len(), 2);
        assert_eq!(kept.new, vec![Name::new(me, 1), Name::new(me, 2)]);
        assert!(kept.refused.is_empty());
        // Its age counts from before it came: due 10 ticks on, born 4 ticks back.
        let due = outstanding.take_due(110);
        assert_eq!(due.len(), 2);
        assert!(
            due.iter()
                .all(|(_, u)| u.born_tick == 96 && u.age(110) == 14)
        );
        for (key, u) in due {
            assert!(outstanding.keep(key, u));
        }
        // A resend is sent and not new; an op forwarded for another issuer keeps its name.
        let forwarded = RoutedOp {
            issuer: Some(ClusterId::from_u128(5)),
            ..op(1)
        };
        let kept = outstanding.keep_sent(me, to, vec![op(1), forwarded], 111, 10);
        assert_eq!(kept.send.len(), 2);
        assert_eq!(kept.new, vec![Name::new(ClusterId::from_u128(5), 1)]);
        // Past the bound for one destination: refused, not sent.
        for seq in 1_000..1_000 + MAX_UNANSWERED as u64 {
            outstanding.keep(Name::new(me, seq), unanswered(2, 200));
        }
        let kept = outstanding.keep_sent(me, to, vec![op(7)], 112, 10);
        assert!(kept.send.is_empty() && kept.new.is_empty());
        assert_eq!(kept.refused, vec![Name::new(me, 7)]);
    }
}
