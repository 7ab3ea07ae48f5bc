//! The transport contract, written once and run on every backend (`shm::`, `local::`, `redis::`,
//! `redis_cluster::`).

use std::time::Duration;

use seam_tests::{PATIENCE, SILENCE, TestContext, publish_until_received, receive};
use seam_transport::{Backend, ChannelError, PublishError, SubscribeError};

seam_tests::backend_tests!(
    [shm: Shm, local: Local, redis: Redis, redis_cluster: RedisCluster],
    [round_trip,
    receiver_counts,
    unsubscribe_stops_delivery,
    pattern_subscriptions,
    per_publisher_order,
    payload_sizes_up_to_max,
    many_channels,
    several_publishers_one_channel,
    overflow_is_counted_not_blocking,
    bad_input_rejected,
    writer_errors,
    receive_waits_without_spinning,
    wakes_on_publish_from_another_thread,
    advertise_prepares_publishing,
    forward_keeps_the_envelope,
    keyed_frames_refuse_strangers,
    signed_frames_name_their_signer]
);

fn round_trip(ctx: &TestContext) {
    let (mut publisher, mut subscriber) = (ctx.open(), ctx.open());
    let channel = ctx.channel("round_trip");
    subscriber.subscribe(&channel).expect("subscribe");
    assert_eq!(publisher.publish(&channel, b"hello").expect("publish"), 1);
    let message = receive(subscriber.as_mut(), PATIENCE).expect("the message arrives");
    assert_eq!(message.channel, channel);
    assert_eq!(message.pattern, None);
    assert_eq!(message.payload, b"hello");
    assert!(
        subscriber.try_receive().expect("receive").is_none(),
        "delivered once"
    );
    assert_eq!(publisher.stats().published, 1);
    assert_eq!(subscriber.stats().received, 1);
}

fn receiver_counts(ctx: &TestContext) {
    let mut publisher = ctx.open();
    let channel = ctx.channel("counts");
    assert_eq!(publisher.publish(&channel, b"x").expect("publish"), 0);
    let mut subscribers: Vec<_> = (0..3).map(|_| ctx.open()).collect();
    for subscriber in &mut subscribers {
        subscriber.subscribe(&channel).expect("subscribe");
    }
    assert_eq!(publisher.publish(&channel, b"y").expect("publish"), 3);
    for subscriber in &mut subscribers {
        let message = receive(subscriber.as_mut(), PATIENCE).expect("each subscriber receives");
        assert_eq!(message.payload, b"y");
    }
}

fn unsubscribe_stops_delivery(ctx: &TestContext) {
    let (mut publisher, mut subscriber) = (ctx.open(), ctx.open());
    let channel = ctx.channel("unsub");
    subscriber.subscribe(&channel).expect("subscribe");
    assert_eq!(publisher.publish(&channel, b"1").expect("publish"), 1);
    assert!(receive(subscriber.as_mut(), PATIENCE).is_some());
    subscriber.unsubscribe(&channel).expect("unsubscribe");
    assert_eq!(publisher.publish(&channel, b"2").expect("publish"), 0);
    assert_eq!(receive(subscriber.as_mut(), SILENCE), None);
}

fn pattern_subscriptions(ctx: &TestContext) {
    let (mut publisher, mut subscriber) = (ctx.open(), ctx.open());
    let pattern = ctx.channel("events:*");
    if ctx.backend() == Backend::RedisCluster {
        // Sharded pub/sub has no patterns: refused, saying so, not silently empty.
        let refused = subscriber.psubscribe(&pattern).expect_err("no patterns");
        assert!(
            matches!(refused, SubscribeError::Unsupported { .. })
                && refused.to_string().contains("patterns"),
            "{refused}"
        );
        return;
    }
    subscriber.psubscribe(&pattern).expect("psubscribe");
    for name in ["events:a", "events:b"] {
        let channel = ctx.channel(name);
        let message = publish_until_received(
            publisher.as_mut(),
            subscriber.as_mut(),
            &channel,
            b"p",
            PATIENCE,
        );
        assert_eq!(message.channel, channel);
        assert_eq!(message.pattern.as_deref(), Some(pattern.as_str()));
        assert_eq!(message.payload, b"p");
    }
    // A channel the pattern does not match never arrives.
    let other = ctx.channel("replication:a");
    assert_eq!(publisher.publish(&other, b"no").expect("publish"), 0);
    assert_eq!(receive(subscriber.as_mut(), SILENCE), None);

    subscriber.punsubscribe(&pattern).expect("punsubscribe");
    assert_eq!(
        publisher
            .publish(&ctx.channel("events:a"), b"late")
            .expect("publish"),
        0
    );
    assert_eq!(receive(subscriber.as_mut(), SILENCE), None);
}

fn per_publisher_order(ctx: &TestContext) {
    let (mut publisher, mut subscriber) = (ctx.open(), ctx.open());
    let channel = ctx.channel("order");
    subscriber.subscribe(&channel).expect("subscribe");
    let mut expected = 0u32;
    for batch in 0..250u32 {
        // Batches smaller than any receive buffer: order, not overflow, is under test.
        for i in 0..8 {
            publisher
                .publish(&channel, &(batch * 8 + i).to_le_bytes())
                .expect("publish");
        }
        for _ in 0..8 {
            let message = receive(subscriber.as_mut(), PATIENCE).expect("arrives");
            let value = u32::from_le_bytes(message.payload.try_into().expect("4 bytes"));
            assert_eq!(value, expected, "messages arrive in publish order");
            expected += 1;
        }
    }
    assert_eq!(subscriber.stats().overflow_drops, 0);
}

fn payload_sizes_up_to_max(ctx: &TestContext) {
    let (mut publisher, mut subscriber) = (ctx.open(), ctx.open());
    let channel = ctx.channel("sizes");
    subscriber.subscribe(&channel).expect("subscribe");
    let max = publisher.max_payload();
    assert_eq!(max, 4 << 20, "the default maximum is 4 MiB");
    for size in [0, 1, 63, 64, 4095, 4096, 65_536, 1 << 20, max] {
        let payload: Vec<u8> = (0..size).map(|i| (i * 31 % 251) as u8).collect();
        assert_eq!(
            publisher.publish(&channel, &payload).expect("publish"),
            1,
            "size {size}"
        );
        let message = receive(subscriber.as_mut(), PATIENCE).expect("arrives");
        assert_eq!(message.payload.len(), size);
        assert!(message.payload == payload, "payload of {size} bytes intact");
    }
    assert_eq!(
        publisher.publish(&channel, &vec![0; max + 1]),
        Err(PublishError::PayloadTooLarge { len: max + 1, max })
    );
}

fn many_channels(ctx: &TestContext) {
    let (mut publisher, mut subscriber) = (ctx.open(), ctx.open());
    let channels: Vec<String> = (0..256)
        .map(|i| ctx.channel(&format!("many:{i}")))
        .collect();
    for channel in &channels {
        subscriber.subscribe(channel).expect("subscribe");
    }
    for (i, channel) in channels.iter().enumerate() {
        assert_eq!(
            publisher
                .publish(channel, &(i as u32).to_le_bytes())
                .expect("publish"),
            1
        );
    }
    let mut seen = vec![false; channels.len()];
    for _ in 0..channels.len() {
        let message = receive(subscriber.as_mut(), PATIENCE).expect("arrives");
        let i = u32::from_le_bytes(message.payload.try_into().expect("4 bytes")) as usize;
        assert_eq!(message.channel, channels[i], "payload matches its channel");
        assert!(!seen[i], "channel {i} delivered once");
        seen[i] = true;
    }
    assert!(seen.iter().all(|s| *s));
}

fn several_publishers_one_channel(ctx: &TestContext) {
    let mut subscriber = ctx.open();
    let channel = ctx.channel("fan_in");
    subscriber.subscribe(&channel).expect("subscribe");
    let mut publishers: Vec<_> = (0..4).map(|_| ctx.open()).collect();
    for round in 0..3u8 {
        for (p, publisher) in publishers.iter_mut().enumerate() {
            assert_eq!(
                publisher
                    .publish(&channel, &[p as u8, round])
                    .expect("publish"),
                1
            );
        }
    }
    let mut next_round = [0u8; 4];
    for _ in 0..12 {
        let message = receive(subscriber.as_mut(), PATIENCE).expect("arrives");
        let (p, round) = (message.payload[0] as usize, message.payload[1]);
        assert_eq!(
            round, next_round[p],
            "each publisher's messages stay in order"
        );
        next_round[p] += 1;
    }
    assert_eq!(next_round, [3; 4]);
}

fn overflow_is_counted_not_blocking(ctx: &TestContext) {
    let mut publisher = ctx.open_with("buffer=4");
    let mut subscriber = ctx.open_with("buffer=4");
    let channel = ctx.channel("overflow");
    subscriber.subscribe(&channel).expect("subscribe");
    // The first message sets the receiver's baseline for this publisher.
    publisher.publish(&channel, b"first").expect("publish");
    assert!(receive(subscriber.as_mut(), PATIENCE).is_some());
    const FLOOD: u64 = 100;
    for i in 0..FLOOD {
        publisher
            .publish(&channel, &i.to_le_bytes())
            .expect("a full receiver never blocks");
    }
    // The last message published must arrive: newest data wins.
    let mut last = None;
    let mut received = 0;
    while let Some(message) = receive(subscriber.as_mut(), SILENCE) {
        last = Some(u64::from_le_bytes(
            message.payload.try_into().expect("8 bytes"),
        ));
        received += 1;
    }
    let stats = subscriber.stats();
    assert_eq!(last, Some(FLOOD - 1), "the newest message survives");
    assert_eq!(
        received + stats.overflow_drops,
        FLOOD,
        "every message is received or counted"
    );
    if !ctx.is_redis() {
        assert!(
            received <= 4,
            "a buffer of 4 holds at most 4, got {received}"
        );
        assert!(stats.overflow_drops >= FLOOD - 4);
    }
}

fn bad_input_rejected(ctx: &TestContext) {
    let mut transport = ctx.open();
    let long = "x".repeat(256);
    assert_eq!(
        transport.publish("", b"x"),
        Err(PublishError::Channel(ChannelError::Empty))
    );
    assert_eq!(
        transport.publish(&long, b"x"),
        Err(PublishError::Channel(ChannelError::TooLong {
            len: 256,
            max: 255
        }))
    );
    assert_eq!(
        transport.publish("two words", b"x"),
        Err(PublishError::Channel(ChannelError::NotPrintableAscii {
            position: 3
        }))
    );
    assert_eq!(
        transport.subscribe("grüße"),
        Err(SubscribeError::Channel(ChannelError::NotPrintableAscii {
            position: 2
        }))
    );
    assert_eq!(
        transport.psubscribe(""),
        Err(SubscribeError::Channel(ChannelError::Empty))
    );
    let error = transport.publish("", b"x").expect_err("empty channel");
    assert!(
        error.to_string().contains("empty"),
        "message says what is wrong: {error}"
    );
    // The transport still works after rejecting bad input.
    let channel = ctx.channel("after_bad_input");
    transport.subscribe(&channel).expect("subscribe");
    assert_eq!(transport.publish(&channel, b"ok").expect("publish"), 1);
    assert_eq!(
        receive(transport.as_mut(), PATIENCE)
            .expect("arrives")
            .payload,
        b"ok"
    );
}

fn writer_errors(ctx: &TestContext) {
    let (mut publisher, mut subscriber) = (ctx.open(), ctx.open());
    let channel = ctx.channel("writer");
    subscriber.subscribe(&channel).expect("subscribe");
    assert_eq!(
        publisher.publish_with(&channel, 16, &mut |_| None),
        Err(PublishError::WriterAborted)
    );
    assert_eq!(
        publisher.publish_with(&channel, 16, &mut |_| Some(17)),
        Err(PublishError::WriterOverrun {
            written: 17,
            capacity: 16
        })
    );
    // Only what the writer reports is sent, and nothing of the failed attempts.
    let reached = publisher
        .publish_with(&channel, 64, &mut |buffer| {
            assert!(buffer.iter().all(|b| *b == 0), "the buffer comes zeroed");
            buffer[..3].copy_from_slice(b"abc");
            Some(3)
        })
        .expect("publish");
    assert_eq!(reached, 1);
    assert_eq!(
        receive(subscriber.as_mut(), PATIENCE)
            .expect("arrives")
            .payload,
        b"abc"
    );
    assert_eq!(receive(subscriber.as_mut(), SILENCE), None);
    assert_eq!(
        subscriber.stats().overflow_drops,
        0,
        "aborted publishes leave no gap"
    );
}

/// CPU time of this thread so far, from /proc (user + system, in clock ticks of 10 ms).
/// CPU time this thread has used.
fn thread_cpu() -> Duration {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ThreadCPUTime);
    Duration::new(t.tv_sec as u64, t.tv_nsec as u32)
}

fn receive_waits_without_spinning(ctx: &TestContext) {
    let mut subscriber = ctx.open();
    subscriber
        .subscribe(&ctx.channel("quiet"))
        .expect("subscribe");
    let wall = std::time::Instant::now();
    let before = thread_cpu();
    assert_eq!(
        receive(subscriber.as_mut(), Duration::from_millis(600)),
        None
    );
    let (cpu, elapsed) = (thread_cpu() - before, wall.elapsed());
    assert!(
        elapsed >= Duration::from_millis(600),
        "waited the whole timeout"
    );
    // A sleeping wait uses well under a millisecond of CPU; one that spins even a twentieth of
    // the time uses 30 ms.
    assert!(
        cpu < Duration::from_millis(30),
        "a 600 ms wait used {cpu:?} of CPU: it spins"
    );
}

fn wakes_on_publish_from_another_thread(ctx: &TestContext) {
    let mut subscriber = ctx.open();
    let channel = ctx.channel("wake");
    subscriber.subscribe(&channel).expect("subscribe");
    let url = ctx.url();
    let (go_tx, go_rx) = std::sync::mpsc::channel::<()>();
    let (done_tx, done_rx) = std::sync::mpsc::channel::<()>();
    let thread_channel = channel.clone();
    let publisher = std::thread::spawn(move || {
        let mut publisher = seam_transport::open(&url).expect("open");
        go_rx.recv().expect("go");
        // Give the subscriber time to fall asleep, so the wake-up path is what is tested.
        std::thread::sleep(Duration::from_millis(50));
        let published = std::time::Instant::now();
        let reached = publisher
            .publish(&thread_channel, b"wake up")
            .expect("publish");
        // On shared memory a publisher's unread samples go with it; stay until received.
        done_rx.recv_timeout(Duration::from_secs(40)).ok();
        (reached, published)
    });
    go_tx.send(()).expect("go");
    let message = receive(subscriber.as_mut(), Duration::from_secs(30)).expect("woken");
    let received = std::time::Instant::now();
    done_tx.send(()).expect("done");
    assert_eq!(message.payload, b"wake up");
    let (reached, published) = publisher.join().expect("publisher thread");
    assert_eq!(reached, 1);
    // Woken by the publish: a wake-up takes microseconds (a scheduler delay on a busy machine,
    // milliseconds); a wait that only noticed the message on a poll or at its 30 s timeout
    // takes far longer.
    let latency = received.duration_since(published);
    assert!(
        latency < Duration::from_millis(300),
        "woken {latency:?} after the publish: not by it"
    );
}

/// Shared-memory files of this test's transports.
fn shm_files(ctx: &TestContext) -> usize {
    let prefix = ctx.prefix().expect("an iceoryx2 backend");
    std::fs::read_dir("/dev/shm")
        .expect("/dev/shm")
        .filter_map(Result::ok)
        .filter(|entry| entry.file_name().to_string_lossy().starts_with(&prefix))
        .count()
}

fn advertise_prepares_publishing(ctx: &TestContext) {
    let (mut publisher, mut subscriber) = (ctx.open(), ctx.open());
    let channel = ctx.channel("advertised");
    subscriber.subscribe(&channel).expect("subscribe");
    let files = |ctx: &TestContext| (ctx.backend() == Backend::Shm).then(|| shm_files(ctx));
    let before = files(ctx);
    publisher
        .advertise(&channel, 100_000)
        .expect("advertise with room for 100 kB");
    // On shm, advertising sets up the publisher's shared memory now (a new segment), so that
    // publishing up to the advertised size sets up nothing more. (Local shares the code; Redis
    // has nothing to prepare.)
    let advertised = files(ctx);
    if let (Some(before), Some(advertised)) = (before, advertised) {
        assert!(
            advertised > before,
            "advertise made the publisher's shared memory ({before} files before, {advertised} after)"
        );
    }
    assert_eq!(
        publisher.stats().published,
        0,
        "advertising publishes nothing"
    );
    assert!(
        subscriber.try_receive().expect("receive").is_none(),
        "nothing arrives from advertising"
    );
    // Larger than advertised still goes (the shared memory grows), and so does smaller.
    for size in [10, 100_000, 300_000] {
        let payload = vec![size as u8; size];
        assert_eq!(publisher.publish(&channel, &payload).expect("publish"), 1);
        let message = receive(subscriber.as_mut(), PATIENCE).expect("arrives");
        assert_eq!(message.payload.len(), size);
        if size <= 100_000 {
            assert_eq!(
                files(ctx),
                advertised,
                "a publish within the advertised room set nothing up"
            );
        }
    }
    assert_eq!(
        publisher.advertise("", 10),
        Err(PublishError::Channel(ChannelError::Empty)),
        "a bad channel name is refused"
    );
}

/// A message passed on with `forward` reaches its receiver under its first publisher's identity
/// and number: the receiver counts a gap in the original numbering as a loss, and the
/// forwarding transport's own numbering on the channel is untouched.
fn forward_keeps_the_envelope(ctx: &TestContext) {
    let (mut origin, mut first_hop, mut bridge, mut last_hop) =
        (ctx.open(), ctx.open(), ctx.open(), ctx.open());
    let (channel, onward) = (ctx.channel("forward_in"), ctx.channel("forward_out"));
    first_hop.subscribe(&channel).expect("subscribe");
    last_hop.subscribe(&onward).expect("subscribe");
    let mut received = Vec::new();
    for payload in [&b"one"[..], b"two", b"three"] {
        origin.publish(&channel, payload).expect("publish");
        received.push(receive(first_hop.as_mut(), PATIENCE).expect("the message arrives"));
    }
    assert_eq!(
        received.iter().map(|m| m.origin.seq).collect::<Vec<_>>(),
        [1, 2, 3]
    );
    assert!(
        received
            .iter()
            .all(|m| m.origin.publisher == received[0].origin.publisher)
    );
    // Pass on the first and the third: the second is lost on the way.
    for message in [&received[0], &received[2]] {
        assert_eq!(
            bridge
                .forward(&onward, message.origin, &message.payload)
                .expect("forward"),
            1
        );
    }
    let first = receive(last_hop.as_mut(), PATIENCE).expect("the forwarded message arrives");
    let third = receive(last_hop.as_mut(), PATIENCE).expect("the forwarded message arrives");
    assert_eq!(
        (first.payload.as_slice(), third.payload.as_slice()),
        (&b"one"[..], &b"three"[..])
    );
    assert_eq!(
        first.origin, received[0].origin,
        "the original envelope arrives"
    );
    assert_eq!(third.origin, received[2].origin);
    assert_eq!(
        last_hop.stats().overflow_drops,
        1,
        "the receiver counts the message lost between the hops"
    );
    // A batch goes out in order, each message under its own envelope.
    let batch: Vec<_> = received
        .iter()
        .rev()
        .map(|m| seam_transport::OwnedMessage {
            channel: onward.clone(),
            ..m.clone()
        })
        .collect();
    assert_eq!(bridge.forward_all(&batch).expect("forward_all"), 3);
    for expected in &batch {
        let got = receive(last_hop.as_mut(), PATIENCE).expect("a batched message arrives");
        assert_eq!(
            (got.origin, &got.payload),
            (expected.origin, &expected.payload)
        );
    }
    // The bridge's own numbering on the channel starts at 1, whatever it forwarded.
    bridge.publish(&onward, b"own").expect("publish");
    let own = receive(last_hop.as_mut(), PATIENCE).expect("arrives");
    assert_eq!(own.origin.seq, 1);
    assert_ne!(own.origin.publisher, first.origin.publisher);
}

/// A transport of this test's backend with a frame key (`None`: none).
fn keyed(ctx: &TestContext, key: Option<&str>) -> Box<dyn seam_transport::Transport> {
    match key {
        Some(key) => with(ctx, &format!("key={key}")),
        None => ctx.open(),
    }
}

/// The URL of this test's backend with the seam settings `settings` (on every backend).
fn url_of(ctx: &TestContext, settings: &str) -> String {
    match ctx.backend() {
        Backend::Redis | Backend::RedisCluster => format!("{}?{settings}", ctx.url()),
        _ => ctx.url_with(settings),
    }
}

/// A transport of this test's backend with the seam settings `settings`.
fn with(ctx: &TestContext, settings: &str) -> Box<dyn seam_transport::Transport> {
    let url = url_of(ctx, settings);
    seam_transport::open(&url).unwrap_or_else(|e| panic!("cannot open {url}: {e}"))
}

/// With a key set, a receiver hands over only messages tagged with it: frames from a
/// publisher without the key, or with another, are dropped and counted by reason; a bridge
/// without the key passes keyed frames on intact; and the key never shows in a redacted URL.
fn keyed_frames_refuse_strangers(ctx: &TestContext) {
    let channel = ctx.channel("keyed");
    let mut receiver = keyed(ctx, Some("alpha"));
    receiver.subscribe(&channel).expect("subscribe");
    let mut friend = keyed(ctx, Some("alpha"));
    let mut stranger = keyed(ctx, None);
    let mut forger = keyed(ctx, Some("beta"));
    for _ in 0..3 {
        stranger.publish(&channel, b"no tag").expect("publish");
        forger.publish(&channel, b"wrong key").expect("publish");
    }
    friend.publish(&channel, b"friend").expect("publish");
    let message = receive(receiver.as_mut(), PATIENCE).expect("the keyed message arrives");
    assert_eq!(message.payload, b"friend");
    assert!(
        receive(receiver.as_mut(), SILENCE).is_none(),
        "nothing else"
    );
    let stats = receiver.stats();
    assert_eq!(
        (stats.untagged_drops, stats.bad_tag_drops),
        (3, 3),
        "{stats:?}"
    );
    assert_eq!(stats.received, 1);
    // Through a bridge that has no key: the tag travels with the message.
    let (onward, mut first_hop, mut bridge) =
        (ctx.channel("keyed_on"), keyed(ctx, None), keyed(ctx, None));
    let mut last_hop = keyed(ctx, Some("alpha"));
    first_hop.subscribe(&channel).expect("subscribe");
    last_hop.subscribe(&onward).expect("subscribe");
    friend.publish(&channel, b"relayed").expect("publish");
    let relayed = receive(first_hop.as_mut(), PATIENCE).expect("arrives unchecked");
    bridge
        .forward(&onward, relayed.origin, &relayed.payload)
        .expect("forward");
    // Forwarded to another channel the tag no longer matches (it binds the channel)...
    assert!(receive(last_hop.as_mut(), SILENCE).is_none());
    assert_eq!(last_hop.stats().bad_tag_drops, 1);
    // ... and on its own channel it is accepted.
    let mut same = keyed(ctx, Some("alpha"));
    same.subscribe(&channel).expect("subscribe");
    bridge
        .forward(&channel, relayed.origin, &relayed.payload)
        .expect("forward");
    let through = receive(same.as_mut(), PATIENCE).expect("the keyed frame passes the bridge");
    assert_eq!(through.payload, b"relayed");
    let url = ctx.url_with("key=alpha");
    assert!(!seam_transport::redact_url(&url).contains("alpha"), "{url}");
}

/// With a keyring set, a receiver hands over only messages a signer it holds signed, each
/// with that signer: a message with no signature, one by a signer the keyring lacks, and every
/// forgery a bridge can make of a genuine one (signer changed, payload or numbering changed,
/// another channel, signatures made up) is dropped and counted; the genuine one passes a
/// bridge with its signature; and a receiver without a keyring names no signer.
fn signed_frames_name_their_signer(ctx: &TestContext) {
    use seam_transport::signing::{Keyring, Signer};
    let dir = std::env::temp_dir().join(format!("seam-signed-{}", ctx.channel("keys")));
    std::fs::create_dir_all(&dir).expect("key dir");
    let (west, east, stranger) = (
        Signer::generate(0x1001).expect("random"),
        Signer::generate(0x1002).expect("random"),
        Signer::generate(0x1003).expect("random"),
    );
    let file = |name: &str| dir.join(name).to_str().expect("utf-8").to_owned();
    for (signer, name) in [(&west, "west"), (&east, "east"), (&stranger, "stranger")] {
        signer
            .write_file(std::path::Path::new(&file(name)))
            .expect("key file");
    }
    Keyring::of([&west, &east])
        .write_file(std::path::Path::new(&file("keyring")))
        .expect("keyring");
    let ring = format!("keyring={}", file("keyring"));
    let signing = |name: &str| with(ctx, &format!("sign_key={}", file(name)));
    let channel = ctx.channel("signed");
    let mut receiver = with(ctx, &ring);
    let mut blind = ctx.open();
    for r in [&mut receiver, &mut blind] {
        r.subscribe(&channel).expect("subscribe");
    }
    let (mut from_west, mut from_east) = (signing("west"), signing("east"));
    let (mut unsigned, mut strange) = (ctx.open(), signing("stranger"));
    for _ in 0..3 {
        unsigned.publish(&channel, b"unsigned").expect("publish");
        strange.publish(&channel, b"stranger").expect("publish");
    }
    from_west.publish(&channel, b"west").expect("publish");
    from_east.publish(&channel, b"east").expect("publish");
    let mut got: Vec<(Vec<u8>, Option<u128>)> = (0..2)
        .map(|_| {
            let m = receive(receiver.as_mut(), PATIENCE).expect("a signed message arrives");
            (m.payload, m.signer)
        })
        .collect();
    got.sort();
    assert_eq!(
        got,
        vec![
            (b"east".to_vec(), Some(0x1002)),
            (b"west".to_vec(), Some(0x1001))
        ]
    );
    assert!(
        receive(receiver.as_mut(), SILENCE).is_none(),
        "nothing else"
    );
    let stats = receiver.stats();
    assert_eq!(
        (stats.unsigned_drops, stats.forged_drops, stats.received),
        (3, 3, 2),
        "{stats:?}"
    );
    let mut seen_blind = 0;
    while let Some(m) = receive(blind.as_mut(), SILENCE) {
        assert_eq!(m.signer, None, "no keyring, no signer named");
        seen_blind += 1;
    }
    assert_eq!(
        seen_blind, 8,
        "a receiver without a keyring takes everything"
    );

    // Forgeries of a genuine message, forwarded by a bridge that holds no key.
    let genuine = {
        let mut tap = ctx.open();
        tap.subscribe(&channel).expect("subscribe");
        from_west.publish(&channel, b"genuine").expect("publish");
        receive(tap.as_mut(), PATIENCE).expect("arrives")
    };
    let _ = receive(receiver.as_mut(), PATIENCE).expect("the genuine one, straight");
    let mut bridge = ctx.open();
    let other = ctx.channel("signed_other");
    let mut elsewhere = with(ctx, &ring);
    elsewhere.subscribe(&other).expect("subscribe");
    let o = genuine.origin;
    let mut forged = 0u64;
    let mut forge = |bridge: &mut Box<dyn seam_transport::Transport>,
                     on: &str,
                     origin: seam_transport::Origin,
                     payload: &[u8]| {
        bridge.forward(on, origin, payload).expect("forward");
        forged += 1;
        // Taken as they come, so none is lost to a full buffer (shm keeps 16) uncounted.
        let reached = receiver.try_receive().expect("receive").is_some();
        assert!(!reached, "a forgery reached the caller");
    };
    use seam_transport::Origin;
    let changed: [(Origin, &[u8]); 5] = [
        (
            Origin {
                signer: 0x1002,
                ..o
            },
            b"genuine",
        ),
        (
            Origin {
                signer: 0x1003,
                ..o
            },
            b"genuine",
        ),
        (o, b"Genuine"),
        (
            Origin {
                seq: o.seq + 7,
                ..o
            },
            b"genuine",
        ),
        (
            Origin {
                publisher: o.publisher ^ 1,
                ..o
            },
            b"genuine",
        ),
    ];
    for (origin, payload) in changed {
        forge(&mut bridge, &channel, origin, payload);
    }
    let mut noise = 0x9e37_79b9_7f4a_7c15u64;
    for i in 0..200u32 {
        let mut signature = [0u8; 64];
        for chunk in signature.chunks_mut(8) {
            noise ^= noise << 13;
            noise ^= noise >> 7;
            noise ^= noise << 17;
            chunk.copy_from_slice(&noise.to_le_bytes());
        }
        let signer = if i % 2 == 0 { 0x1001 } else { 0x1002 };
        forge(
            &mut bridge,
            &channel,
            seam_transport::Origin {
                signer,
                signature,
                ..o
            },
            b"made up",
        );
    }
    // On another channel the genuine signature no longer matches (it binds the channel).
    bridge.forward(&other, o, b"genuine").expect("forward");
    assert!(receive(elsewhere.as_mut(), SILENCE).is_none());
    assert_eq!(elsewhere.stats().forged_drops, 1);
    // ... and on its own channel it passes, with its signer.
    bridge.forward(&channel, o, b"genuine").expect("forward");
    let through = receive(receiver.as_mut(), PATIENCE).expect("the genuine one passes the bridge");
    assert_eq!(
        (through.payload.as_slice(), through.signer),
        (&b"genuine"[..], Some(0x1001))
    );
    assert!(
        receive(receiver.as_mut(), SILENCE).is_none(),
        "no forgery reached the caller"
    );
    assert_eq!(
        receiver.stats().forged_drops - stats.forged_drops,
        forged,
        "every forgery refused"
    );
    let refused = seam_transport::open(&url_of(ctx, "keyring=/nonexistent/keyring"));
    let error = refused
        .err()
        .expect("a keyring that cannot be read is refused")
        .to_string();
    assert!(error.contains("/nonexistent/keyring"), "{error}");
    std::fs::remove_dir_all(&dir).expect("clean up");
}
