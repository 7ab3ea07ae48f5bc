//! Replication between keyframes (`ClusterConfig::keyframe_ticks`): delta frames give a
//! neighbour exactly the states full frames give, and with frames dropped on purpose —
//! keyframes among them — no proxy is staler than the keyframe interval, none is lost and none
//! is despawned.

use std::collections::HashMap;
use std::time::Duration;

use seam_proxy::{Cluster, ClusterConfig, lockstep_round};
use seam_sim::BodyRole;
use seam_sim::wire::{ClusterId, EntityId, EntityState, ReplicationView};
use seam_tests::{HandClock, ball_at};
use seam_transport::{
    Backend, Message, PublishError, ReceiveError, Stats, SubscribeError, Transport,
};

const TIMEOUT: Duration = Duration::from_secs(10);

/// A real transport that drops the replication frames `drop` picks (given the frame's tick
/// and whether it is a keyframe) instead of publishing them.
struct Dropping {
    inner: Box<dyn Transport>,
    drop: Box<dyn FnMut(u64, bool) -> bool>,
    scratch: Vec<u8>,
}

impl Transport for Dropping {
    fn backend(&self) -> Backend {
        self.inner.backend()
    }

    fn publish_with(
        &mut self,
        channel: &str,
        capacity: usize,
        write: &mut dyn FnMut(&mut [u8]) -> Option<usize>,
    ) -> Result<usize, PublishError> {
        if !channel.starts_with("replication") {
            return self.inner.publish_with(channel, capacity, write);
        }
        self.scratch.clear();
        self.scratch.resize(capacity, 0);
        let Some(len) = write(&mut self.scratch) else {
            return Ok(0);
        };
        let view = ReplicationView::parse(&self.scratch[..len]).expect("a frame");
        let key = view.delta().is_none();
        if (self.drop)(view.tick(), key) {
            return Ok(1);
        }
        self.inner.publish(channel, &self.scratch[..len])
    }

    fn claim(&mut self, name: &str, holder: &str) -> Result<u64, seam_transport::ClaimError> {
        self.inner.claim(name, holder)
    }

    fn forward(
        &mut self,
        channel: &str,
        origin: seam_transport::Origin,
        payload: &[u8],
    ) -> Result<usize, PublishError> {
        self.inner.forward(channel, origin, payload)
    }

    fn subscribe(&mut self, channel: &str) -> Result<(), SubscribeError> {
        self.inner.subscribe(channel)
    }

    fn unsubscribe(&mut self, channel: &str) -> Result<(), SubscribeError> {
        self.inner.unsubscribe(channel)
    }

    fn psubscribe(&mut self, pattern: &str) -> Result<(), SubscribeError> {
        self.inner.psubscribe(pattern)
    }

    fn punsubscribe(&mut self, pattern: &str) -> Result<(), SubscribeError> {
        self.inner.punsubscribe(pattern)
    }

    fn try_receive(&mut self) -> Result<Option<Message<'_>>, ReceiveError> {
        self.inner.try_receive()
    }

    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<Message<'_>>, ReceiveError> {
        self.inner.receive_timeout(timeout)
    }

    fn stats(&self) -> Stats {
        self.inner.stats()
    }

    fn max_payload(&self) -> usize {
        self.inner.max_payload()
    }
}

/// West owning three bodies at rest and one moving at 1 m/s, and east modelling them all,
/// without gravity; replication every tick, a keyframe every `keyframe_ticks`.
fn pair(
    test: &str,
    keyframe_ticks: u64,
    west_transport: impl FnOnce(&str) -> Box<dyn Transport>,
) -> (Vec<Cluster>, Vec<EntityId>) {
    let (west, east) = (ClusterId::random(), ClusterId::random());
    let url = format!("local?prefix=seam_{test}_{}_", std::process::id());
    let config = |me, other| {
        let mut config = ClusterConfig::new(me, vec![other], &url);
        config.gravity = [0.0; 3];
        config.keyframe_ticks = keyframe_ticks;
        config
    };
    let mut west_cluster =
        Cluster::with_transport(config(west, east), west_transport(&url)).expect("west");
    let east_cluster = Cluster::new(config(east, west)).expect("east");
    let mut ids = Vec::new();
    for (i, x) in [-6.0, -4.0, -2.0, -8.0].into_iter().enumerate() {
        let mut state = ball_at(x, west);
        if i == 3 {
            state = state.velocity([1.0, 0.0, 0.0]);
        }
        ids.push(state.id);
        west_cluster
            .spawn_owned(&state, BodyRole::Dynamic)
            .expect("west's body");
    }
    (vec![west_cluster, east_cluster], ids)
}

fn proxies(cluster: &Cluster, ids: &[EntityId]) -> Vec<Option<EntityState>> {
    ids.iter().map(|&id| cluster.sim().state(id)).collect()
}

#[test]
fn delta_frames_give_a_neighbour_the_states_full_frames_give() {
    let mut seen = Vec::new();
    let mut unchanged = Vec::new();
    for keyframe_ticks in [1, 8] {
        let test = format!("kf_same_{keyframe_ticks}");
        let (mut clusters, ids) = pair(&test, keyframe_ticks, |url| {
            seam_transport::open(url).expect("local")
        });
        let mut east_saw = Vec::new();
        for _ in 0..40 {
            lockstep_round(&mut clusters, TIMEOUT, |_, _, _| {}).expect("a round");
            // Ids are random per run: the motion is compared.
            let motion = proxies(&clusters[1], &ids)
                .into_iter()
                .map(|s| s.map(|s| (s.position, s.rotation, s.linvel, s.angvel)))
                .collect::<Vec<_>>();
            east_saw.push(motion);
        }
        assert!(
            east_saw
                .last()
                .is_some_and(|last| last.iter().all(Option::is_some)),
            "east models every body"
        );
        seen.push(east_saw);
        unchanged.push(clusters[0].stats().states_unchanged);
    }
    assert_eq!(unchanged[0], 0, "every frame whole");
    assert!(
        unchanged[1] >= 3 * 30,
        "the bodies at rest go as bits between keyframes: {} marked unchanged",
        unchanged[1]
    );
    assert!(
        seen[0] == seen[1],
        "east's proxies differ, tick by tick, between full and delta frames"
    );
}

#[test]
fn with_frames_dropped_no_proxy_is_staler_than_the_keyframe_interval() {
    const K: u64 = 8;
    // The second keyframe is lost, and so are runs of delta frames.
    let mut keyframes = 0;
    let drop = move |tick: u64, key: bool| {
        if key {
            keyframes += 1;
        }
        (key && keyframes == 2) || (3..=5).contains(&(tick % 16))
    };
    let (mut clusters, mut ids) = pair("kf_loss", K, |url| {
        Box::new(Dropping {
            inner: seam_transport::open(url).expect("local"),
            drop: Box::new(drop),
            scratch: Vec::new(),
        })
    });
    let west = clusters[0].id();
    let mut clock = HandClock::new(clusters[0].config().dt);
    // Each body's position after each of west's ticks.
    let mut history: HashMap<EntityId, Vec<(u64, [f32; 3])>> = HashMap::new();
    let mut first_seen: HashMap<EntityId, u64> = HashMap::new();
    // Where each body starts: a pod's first tick sends its frames of tick 0 first.
    for (id, state) in ids.iter().zip(proxies(&clusters[0], &ids)) {
        let state = state.expect("west owns it");
        history.entry(*id).or_default().push((0, state.position));
    }
    for round in 0..60u64 {
        if round == 6 {
            // A body at rest that appears just before the lost keyframe: in it, not in the
            // keyframe before.
            let late = ball_at(-10.0, west);
            ids.push(late.id);
            clusters[0]
                .spawn_owned(&late, BodyRole::Dynamic)
                .expect("a late body");
        }
        let now = clock.advance();
        for cluster in clusters.iter_mut() {
            cluster.tick_at(now, |_, _| {}).expect("a tick");
        }
        let tick = clusters[0].sim().tick();
        for (id, state) in ids.iter().zip(proxies(&clusters[0], &ids)) {
            let state = state.expect("west owns it");
            history.entry(*id).or_default().push((tick, state.position));
            first_seen.entry(*id).or_insert(tick);
        }
        for (id, proxy) in ids.iter().zip(proxies(&clusters[1], &ids)) {
            let born = first_seen[id];
            let Some(proxy) = proxy else {
                assert!(
                    tick <= born + K + 1,
                    "tick {tick}: east has no proxy of a body west has owned since tick {born}"
                );
                continue;
            };
            let fresh_enough = history[id]
                .iter()
                .filter(|(t, _)| *t + K + 1 >= tick)
                .any(|(_, position)| *position == proxy.position);
            assert!(
                fresh_enough,
                "tick {tick}: east's proxy of {id} is at {:?}, where west's body was not in the last {} ticks",
                proxy.position,
                K + 1
            );
        }
    }
    let east = clusters[1].stats();
    assert!(
        east.keyframes_missed > 0,
        "east read delta frames without their keyframe"
    );
    assert_eq!(
        east.proxies_despawned, 0,
        "a lost keyframe despawned proxies"
    );
    assert_eq!(east.proxies_spawned, ids.len() as u64);
}
