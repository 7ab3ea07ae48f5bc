//! The chaos report as one [`Document`]: what was injected and survived, what the pods
//! counted, what every op and report became by name, memory, the result; then the two rows of
//! RELIABILITY.md's tables. Printed as text, or with `--markdown` as RELIABILITY.md quotes it.

use super::{ChaosReport, MEMORY_BOUND_PCT};
use crate::document::{Align::*, Document, Table, grouped};
use crate::ledger::NameCounts;

fn mark(ok: bool) -> &'static str {
    if ok { "" } else { "  <-- MISMATCH" }
}

fn percent(g: Option<f64>) -> String {
    g.map_or("-".to_owned(), |g| format!("{g:+.1} %"))
}

fn pair(a: u64, b: u64) -> String {
    format!("{} / {}", grouped(a), grouped(b))
}

/// The whole report.
pub fn document(r: &ChaosReport) -> Document {
    let mut doc = Document::new();
    doc.line(format!(
        "seam chaos: {} ({} pods) on {}, {:.0} s at {} Hz ({:.1} s wall)",
        r.scene, r.pods, r.transport, r.duration_s, r.rate_hz, r.wall_s
    ));
    doc.line("");
    doc.table(faults_table(r));
    doc.line(injected_lines(r));
    doc.line(counted_lines(r));
    doc.line(owners_line(r));
    for (what, n, counted) in [
        ("ops", &r.by_name.ops, r.ops.counted_routed),
        (
            "contact reports",
            &r.by_name.contacts,
            r.contacts.counted_routed,
        ),
    ] {
        doc.line(by_name_line(what, n, counted));
    }
    if r.by_name.unreadable_lines > 0 {
        doc.line(format!(
            "  ({} ledger lines unreadable: cut short by a kill)",
            r.by_name.unreadable_lines
        ));
    }
    doc.line(recovery_lines(r));
    doc.line("");
    doc.table(memory_table(r));
    doc.line(format!(
        "warm-up = first half of the pod's last life, or until its first hold of its largest \
         custody of a neighbour's bodies ended if that was later; growth = end of run over end \
         of warm-up; peak = largest sample after warm-up over the end of warm-up; each at most \
         +{MEMORY_BOUND_PCT} % (a pod whose last life was too short is not judged){}",
        mark(r.memory_holds())
    ));
    for problem in r
        .failed_faults
        .iter()
        .chain(&r.faults_missing)
        .chain(&r.problems)
    {
        doc.line(format!("problem: {problem}"));
    }
    doc.line("");
    doc.line(if r.holds() {
        "result: every target held"
    } else {
        "result: FAILED (see above)"
    });
    doc.line("");
    doc.line("As RELIABILITY.md's tables quote the run: what was injected and what held, then what else the pods counted.");
    doc.table(held_row(r));
    doc.table(counted_row(r));
    doc
}

fn faults_table(r: &ChaosReport) -> Table {
    let f = &r.faults;
    let mut table = Table::new(&[("fault", Left), ("injected", Right), ("survived", Right)]);
    for (name, n, ok) in [
        ("kill (SIGKILL) + restart --rejoin", f.kill, f.kill_survived),
        ("stop (SIGSTOP 1 s) + continue", f.stop, f.stop_survived),
        (
            "Redis server kill + restart",
            f.redis_restart,
            f.redis_restart_survived,
        ),
        (
            "Redis Cluster primary kill + restart 3 s later",
            f.primary_kill,
            f.primary_kill_survived,
        ),
        (
            "Redis Cluster slot of a live channel moved",
            f.slot_move,
            f.slot_move_survived,
        ),
    ] {
        table.row(vec![name.to_owned(), n.to_string(), ok.to_string()]);
    }
    table
}

/// The frames injected, and whether the pods counted each.
fn injected_lines(r: &ChaosReport) -> String {
    let i = &r.injected;
    let mut out = if r.keyed {
        format!(
            "frames from a process without the key: {} garbage and {} forged published, {} \
             delivered, {} dropped untagged before decoding (decoders saw {}){}",
            i.garbage_frames,
            i.forged_frames,
            i.garbage_deliveries + i.forged_deliveries,
            r.frames.untagged,
            r.garbage_refused() + r.frames.replayed + r.frames.stale,
            mark(r.accounted())
        )
    } else {
        format!(
            "garbage frames: {} published, {} delivered, {} refused{}\n\
             forged ownership claims: {} published, {} delivered, {} seen as replays (or from a \
             pod replaced since){}",
            i.garbage_frames,
            i.garbage_deliveries,
            r.garbage_refused(),
            mark(r.garbage_refused() == i.garbage_deliveries),
            i.forged_frames,
            i.forged_deliveries,
            r.frames.replayed + r.frames.stale,
            mark(r.frames.replayed + r.frames.stale == i.forged_deliveries)
        )
    };
    if !r.accounted() {
        for slip in &r.accounting_slips {
            out += &format!("\n  unseen: {slip}");
        }
    }
    out
}

/// Every entity's owners at every tick, from the pods' owner lines.
fn owners_line(r: &ChaosReport) -> String {
    let o = &r.owners_per_tick;
    let mut out = format!(
        "owners tick by tick: {} entities, {} entity-ticks: {} owned once, {} awaiting adoption \
         after a kill, {} across a stall, {} handed across a stall; {} unowned, {} owned \
         twice{}",
        o.entities,
        o.entity_ticks,
        o.owned_once,
        o.awaiting_adoption,
        o.across_a_stall,
        o.handed_across_a_stall,
        o.unowned,
        o.owned_twice,
        if o.unreadable_lines > 0 {
            format!("; {} owner lines unreadable", o.unreadable_lines)
        } else {
            String::new()
        }
    );
    for example in &o.examples {
        out += &format!("\n  {example}");
    }
    out
}

/// Entities and frames as the counters sum them; ops and contact reports followed by name.
fn counted_lines(r: &ChaosReport) -> String {
    let o = &r.ownership;
    let (fr, op, c) = (&r.frames, &r.ops, &r.contacts);
    format!(
        "entities: {} expected, {} owned once, {} lost, {} owned twice{}\n\
         frames: {} taken; refused: {} undecodable, {} other version, {} wrong sender, {} \
         replayed, {} implausible tick, {} from a replaced pod; {} lost to full buffers; {} \
         states rejected\n\
         ops (by name, every life's ledger): {} routed, {} applied; dropped: {} too old, {} \
         entity gone, {} invalid, {} overflow; {} given up; {} ended twice, {} answered with \
         the end unlogged; {} unanswered at the end, {} with a killed sender; {} lost{}; \
         counted: {} resent, {} repeats not applied, {} forwarded\n\
         contact reports (by name): {} sent, {} surfaced or merged; {} too old, {} given up or \
         the pair the sender's own since; {} ended twice, {} answered with the end unlogged; \
         {} unanswered at the end, {} with a killed sender; {} lost{}; counted: {} resent, {} \
         repeats not surfaced",
        o.expected,
        o.owned_once,
        o.lost.len(),
        o.duplicated.len(),
        if o.names.is_empty() {
            String::new()
        } else {
            format!(" ({})", o.names.join(", "))
        },
        fr.accepted,
        fr.malformed,
        fr.wrong_version,
        fr.wrong_sender,
        fr.replayed,
        fr.implausible,
        fr.stale,
        fr.overflow,
        fr.states_rejected,
        op.routed,
        op.applied,
        op.dropped_stale,
        op.dropped_gone,
        op.dropped_invalid,
        op.dropped_overflow,
        op.given_up,
        op.ended_twice,
        op.end_unlogged,
        op.unanswered_at_end,
        op.unanswered_killed,
        op.lost(),
        mark(op.lost() == 0),
        op.resent,
        op.repeated,
        op.forwarded,
        c.routed,
        c.applied,
        c.dropped_stale,
        c.given_up,
        c.ended_twice,
        c.end_unlogged,
        c.unanswered_at_end,
        c.unanswered_killed,
        c.lost(),
        mark(c.lost() == 0),
        c.resent,
        c.repeated
    )
}

/// Deaths, adoptions and outages; panics.
fn recovery_lines(r: &ChaosReport) -> String {
    let rc = &r.recovery;
    format!(
        "recovery: {} neighbours taken for dead, {} rejoined; {} entities adopted and {} \
         hand-offs reclaimed, {} returned, {} yielded to a later claim{}; {} disconnects, {} \
         reconnects, {:.1} s down (pods summed), {} publishes dropped while down\n\
         panics: {}; pods that ended badly: {}",
        rc.neighbours_lost,
        rc.neighbours_rejoined,
        rc.entities_adopted,
        rc.handoffs_reclaimed,
        rc.entities_returned,
        rc.adoptions_yielded,
        mark(r.adoptions_returned()),
        rc.disconnects,
        rc.reconnects,
        rc.down_s,
        rc.dropped_while_down,
        r.panics,
        r.exited_badly
    )
}

fn memory_table(r: &ChaosReport) -> Table {
    let mut table = Table::new(&[
        ("memory", Left),
        ("warm-up s", Right),
        ("base KiB", Right),
        ("end KiB", Right),
        ("warm-up max", Right),
        ("peak KiB", Right),
        ("growth", Right),
        ("peak", Right),
        ("", Left),
    ]);
    for m in &r.memory {
        table.row(vec![
            m.pod.clone(),
            format!("{:.0}", m.warmup_s),
            m.base_kib.to_string(),
            m.end_kib.to_string(),
            m.warmup_max_kib.to_string(),
            m.max_kib.to_string(),
            percent(m.growth_pct),
            percent(m.peak_growth_pct),
            mark(m.holds() != Some(false)).trim().to_owned(),
        ]);
    }
    table
}

/// What became of the names of one kind, followed across the pods' ledgers.
fn by_name_line(what: &str, n: &NameCounts, counted: u64) -> String {
    let twice: Vec<String> = n
        .ended_twice
        .iter()
        .map(|(ends, count)| format!("{count} {ends}"))
        .collect();
    let mut out = format!(
        "{what} by name: {} sent{}; {} ended once ({} also applied to a stalled owner's \
         adopted copy, since dropped), {} ended twice{}, {} applied twice{}; no end: {} answered \
         (end unlogged), {} unanswered at the end, {} with a killed sender, {} lost{}; {} ended \
         unsent",
        n.sent,
        if n.sent >= counted {
            String::new()
        } else {
            format!(" of {counted} counted  <-- MISMATCH")
        },
        n.ended_once,
        n.applied_to_dropped_copy,
        n.ended_twice_total(),
        if twice.is_empty() {
            String::new()
        } else {
            format!(" ({})", twice.join(", "))
        },
        n.applied_twice,
        mark(n.applied_twice == 0),
        n.answered_end_unlogged,
        n.unanswered_at_end,
        n.with_killed_sender,
        n.lost,
        mark(n.lost == 0),
        n.ended_unsent
    );
    for example in &n.examples {
        out += &format!("\n  {example}");
    }
    out
}

fn transport(r: &ChaosReport) -> &'static str {
    if r.transport.starts_with("redis-cluster") {
        "Redis Cluster"
    } else if r.transport.starts_with("redis") {
        "Redis"
    } else {
        "shm"
    }
}

/// RELIABILITY.md's first table, one row: what was injected and what held.
fn held_row(r: &ChaosReport) -> Table {
    let f = &r.faults;
    let redis_faults = match transport(r) {
        "Redis" => pair(f.redis_restart, f.redis_restart_survived),
        "Redis Cluster" => format!(
            "primary killed {}, slot moved {}",
            pair(f.primary_kill, f.primary_kill_survived),
            pair(f.slot_move, f.slot_move_survived)
        ),
        _ => "—".to_owned(),
    };
    let memory: Vec<String> = r
        .memory
        .iter()
        .map(|m| {
            format!(
                "{} {}, {}",
                m.pod,
                percent(m.growth_pct),
                percent(m.peak_growth_pct)
            )
        })
        .collect();
    let o = &r.ownership;
    let mut held = Table::new(&[
        ("scene", Left),
        ("transport", Left),
        ("s", Right),
        ("pods", Right),
        ("kill", Right),
        ("stop", Right),
        (
            "Redis restart (Redis Cluster: primary killed, slot moved)",
            Right,
        ),
        ("garbage delivered / refused", Right),
        ("forged delivered / replays", Right),
        ("entities expected / once / lost / twice", Left),
        ("adopted + reclaimed / returned", Left),
        ("panics", Right),
        ("memory growth: end, peak", Left),
        ("result", Left),
    ]);
    held.row(vec![
        format!("`{}`", r.scene),
        transport(r).to_owned(),
        format!("{:.0}", r.duration_s),
        r.pods.to_string(),
        pair(f.kill, f.kill_survived),
        pair(f.stop, f.stop_survived),
        redis_faults,
        if r.keyed {
            pair(
                r.injected.garbage_deliveries + r.injected.forged_deliveries,
                r.frames.untagged,
            )
        } else {
            pair(r.injected.garbage_deliveries, r.garbage_refused())
        },
        if r.keyed {
            "(untagged)".to_owned()
        } else {
            pair(
                r.injected.forged_deliveries,
                r.frames.replayed + r.frames.stale,
            )
        },
        format!(
            "{} / {} / {} / {}",
            grouped(o.expected as u64),
            grouped(o.owned_once as u64),
            o.lost.len(),
            o.duplicated.len()
        ),
        format!(
            "{} + {} / {}",
            grouped(r.recovery.entities_adopted),
            grouped(r.recovery.handoffs_reclaimed),
            grouped(r.recovery.entities_returned)
        ),
        r.panics.to_string(),
        memory.join("; "),
        if r.holds() { "held" } else { "FAILED" }.to_owned(),
    ]);
    held
}

/// RELIABILITY.md's second table, one row: what else the pods counted.
fn counted_row(r: &ChaosReport) -> Table {
    let redis = transport(r) == "Redis";
    let (fr, op, rc) = (&r.frames, &r.ops, &r.recovery);
    let mut counted = Table::new(&[
        ("scene", Left),
        ("transport", Left),
        ("frames taken", Right),
        ("lost to full buffers", Right),
        ("implausible", Right),
        ("states rejected", Right),
        ("ops routed / applied / too old / lost", Left),
        ("resent / repeats", Left),
        ("unanswered at end + at kills / ended twice", Left),
        ("contact reports sent / surfaced / too old / lost", Left),
        (
            "by name, ops; reports: ended twice / applied twice / lost",
            Left,
        ),
        ("taken for dead / rejoined", Left),
        (
            "disconnects / reconnects, s down (pods summed), publishes dropped",
            Left,
        ),
    ]);
    counted.row(vec![
        format!("`{}`", r.scene),
        transport(r).to_owned(),
        grouped(fr.accepted),
        grouped(fr.overflow),
        grouped(fr.implausible),
        grouped(fr.states_rejected),
        format!(
            "{} / {} / {} / {}",
            grouped(op.routed),
            grouped(op.applied),
            grouped(op.dropped_stale),
            grouped(op.lost())
        ),
        pair(op.resent, op.repeated),
        format!(
            "{} + {} / {}",
            grouped(op.unanswered_at_end),
            grouped(op.unanswered_killed),
            grouped(op.ended_twice)
        ),
        format!(
            "{} / {} / {} / {}",
            grouped(r.contacts.routed),
            grouped(r.contacts.applied),
            grouped(r.contacts.dropped_stale),
            grouped(r.contacts.lost())
        ),
        {
            let (o, c) = (&r.by_name.ops, &r.by_name.contacts);
            format!(
                "{} / {} / {}; {} / {} / {}",
                grouped(o.ended_twice_total()),
                grouped(o.applied_twice),
                grouped(o.lost),
                grouped(c.ended_twice_total()),
                grouped(c.applied_twice),
                grouped(c.lost)
            )
        },
        pair(rc.neighbours_lost, rc.neighbours_rejoined),
        if redis {
            format!(
                "{} / {}, {:.1} s, {}",
                grouped(rc.disconnects),
                grouped(rc.reconnects),
                rc.down_s,
                grouped(rc.dropped_while_down)
            )
        } else {
            "—".to_owned()
        },
    ]);
    counted
}
