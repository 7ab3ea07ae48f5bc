//! Following the cluster as it changes: channels a node dropped unasked, and links whose
//! primary went down, subscribed again where the slot map now puts them.

use std::time::Instant;

use crate::Transport;

use super::slots::SlotMap;
use super::{REFRESH_WHILE_DOWN, RedisClusterTransport};

impl RedisClusterTransport {
    /// Subscribes again, at the slot's primary now, every channel a node dropped unasked and
    /// every channel on a link that is down, reading the slot map again first (at most every
    /// [`REFRESH_WHILE_DOWN`] while a link is down and nothing was dropped).
    pub(super) fn follow(&mut self) {
        let dropped = self.take_dropped();
        // A link down, or a primary the map names that could not be reached (its link closed
        // already): the map may be stale.
        let stale = self.map_suspect || self.links.iter().any(|l| !l.is_connected());
        if dropped.is_empty() && !(stale && self.last_refresh.elapsed() >= REFRESH_WHILE_DOWN) {
            return;
        }
        self.follow_dropped(&dropped);
    }

    /// Reads the slot map again and moves what it must (see [`Self::follow`]), now.
    pub(super) fn follow_always(&mut self) {
        let dropped = self.take_dropped();
        self.follow_dropped(&dropped);
    }

    /// The channels the links' nodes dropped unasked since last asked.
    fn take_dropped(&mut self) -> Vec<String> {
        (self.links.iter_mut())
            .flat_map(|link| link.take_dropped_by_server())
            .collect()
    }

    fn follow_dropped(&mut self, dropped: &[String]) {
        if !dropped.is_empty() {
            tracing::info!(
                channels = dropped.len(),
                "Redis Cluster node dropped sharded subscriptions (slot moved or primary changed)"
            );
        }
        self.refresh();
        self.move_subscriptions(dropped);
        self.move_leases();
        self.retire_idle_links();
    }

    /// Closes the links that are down and hold nothing (no subscription, no lease: what they
    /// held moved to another primary), keeping their counts: a node that is gone is not
    /// tried again, nor counted as down from then on.
    fn retire_idle_links(&mut self) {
        let mut i = 0;
        while i < self.links.len() {
            let link = &self.links[i];
            if link.is_connected() || link.has_subscriptions() || link.has_leases() {
                i += 1;
                continue;
            }
            self.retired.add(&link.counters());
            self.links.remove(i);
            for (_, at) in &mut self.subscribed {
                if *at > i {
                    *at -= 1;
                }
            }
            self.next = 0;
        }
    }

    /// Reads the slot map again from the first node that gives one: the links' nodes that
    /// are up, then the seeds. Keeps the old map if none does.
    fn refresh(&mut self) {
        self.last_refresh = Instant::now();
        self.map_suspect = false;
        let mut asked: Vec<String> = self
            .links
            .iter()
            .filter(|l| l.is_connected())
            .map(|l| l.addr().to_owned())
            .collect();
        asked.extend(self.seeds.iter().cloned());
        for addr in asked {
            let Ok(index) = self.link(&addr) else {
                continue;
            };
            let reply = self.links[index].query(redis::cmd("CLUSTER").arg("SLOTS"));
            let host = addr
                .rsplit_once(':')
                .map_or(addr.as_str(), |(host, _)| host);
            if let Ok(map) = reply
                .ok()
                .map(|reply| SlotMap::from_reply(&reply, host))
                .transpose()
                .map(Option::unwrap_or_default)
                && map.covers_all()
            {
                self.slots = map;
                return;
            }
        }
    }

    /// Moves each subscription that was `dropped`, or whose link is not the primary of its
    /// slot any more, to that primary (counted in `Stats::resubscribes`). One that cannot be
    /// made now stays where it was, to be tried at the next refresh.
    fn move_subscriptions(&mut self, dropped: &[String]) {
        for at in 0..self.subscribed.len() {
            let (channel, link) = self.subscribed[at].clone();
            let primary = self.slots.primary_of(&channel).to_owned();
            let was_dropped = dropped.contains(&channel);
            if self.links[link].addr() == primary && !was_dropped {
                continue;
            }
            let Ok(to) = self.link(&primary) else {
                self.map_suspect = true;
                continue;
            };
            if self.links[to].subscribe(&channel).is_err() {
                continue;
            }
            if to != link && !was_dropped {
                // Its old node is down or serves the slot no more: not renewed there.
                let _ = self.links[link].unsubscribe(&channel);
            }
            self.subscribed[at].1 = to;
            self.resubscribes += 1;
            tracing::info!(
                channel = %channel,
                node = %primary,
                "sharded channel subscribed again at its slot's primary"
            );
        }
    }

    /// Moves each lease to the link of its key's slot's primary now (after a failover or a
    /// slot move), where it is renewed from then on.
    pub(super) fn move_leases(&mut self) {
        for from in 0..self.links.len() {
            if !self.links[from].has_leases() {
                continue;
            }
            for key in self.links[from].lease_keys() {
                let primary = self.slots.primary_of(&key).to_owned();
                if self.links[from].addr() == primary {
                    continue;
                }
                let Ok(to) = self.link(&primary) else {
                    self.map_suspect = true;
                    continue;
                };
                if let Some(lease) = self.links[from].remove_lease(&key) {
                    self.links[to].give_lease(lease);
                }
            }
        }
    }
}
