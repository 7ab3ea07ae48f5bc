//! `seam` — run and measure seam. See `seam --help`.

mod cli;
mod commands;

use std::process::ExitCode;

use clap::Parser;
use seam_bench::chaos::ChaosPlan;
use seam_bench::node;
use seam_bench::ops::{self, OpsPlan};
use seam_bench::ping::{self, PingPlan};
use seam_bench::run::{self, RunPlan};

use cli::{Cli, Command};
use commands::{chaos, compare, expand_transport, progress, run_scene, seconds, sweep};

fn main() -> ExitCode {
    let cli = Cli::parse();
    seam_bench::console::init_logs();
    let result = match cli.command {
        Command::Run {
            scene,
            transport,
            rate,
            ticks,
            model,
            layers,
            hosts,
            in_phase,
            record,
            output,
        } => run_scene(
            RunPlan {
                rate,
                ticks,
                proxy_mode: model.proxy_mode,
                authority: model.authority,
                replication_interval: model.replication_interval,
                coupling: !model.no_coupling,
                quantize: model.quantize,
                keyframe_ticks: model.keyframe_ticks,
                layers,
                in_phase,
                hosts: run::HostsPlan {
                    count: hosts.hosts,
                    redis: expand_transport(&hosts.redis),
                    delay: seam_bench::relay::Delay {
                        base: std::time::Duration::from_secs_f64(hosts.delay_ms.max(0.0) / 1e3),
                        jitter: std::time::Duration::from_secs_f64(hosts.jitter_ms.max(0.0) / 1e3),
                    },
                    delayed_host: hosts.delayed_host,
                    namespaces: !hosts.no_namespaces,
                },
                ..RunPlan::new(scene, expand_transport(&transport))
            },
            &record,
        )
        .and_then(|report| {
            output.report(&report, run::document);
            if report.ownership.holds() {
                Ok(())
            } else {
                Err(format!(
                    "seam run: {} entities lost and {} owned twice at the end (see the report)",
                    report.ownership.lost.len(),
                    report.ownership.duplicated.len()
                ))
            }
        }),
        Command::Compare {
            scenes,
            knobs,
            trace,
            record,
            output,
        } => compare(
            &scenes,
            &knobs.settings(),
            trace.as_deref(),
            record.as_deref(),
            output,
        ),
        Command::Sweep {
            scenes,
            quick,
            ticks,
            transport,
            rate,
            out,
        } => sweep(scenes, quick, ticks, transport, rate, &out),
        Command::Chaos {
            scene,
            transport,
            duration_s,
            fault_every_s,
            rate,
            layers,
            seed,
            key,
            record,
            output,
        } => chaos(
            ChaosPlan {
                scene,
                redis: transport == "redis",
                rate,
                duration: seconds(duration_s),
                fault_every: seconds(fault_every_s),
                layers,
                seed,
                node_command: Vec::new(),
                key,
                record_dir: None,
            },
            record.as_deref(),
            output,
        ),
        Command::Inspect(args) => commands::inspect(&args),
        Command::Network {
            scenes,
            delays_ms,
            jitter_ms,
            rate,
            in_phase,
            redis,
            out,
        } => commands::network(scenes, delays_ms, jitter_ms, rate, in_phase, &redis, &out),
        Command::Node(args) => node::stop_flag().and_then(|stop| {
            node::run_node(&args, &stop, &mut std::io::stdout().lock()).map(|_| ())
        }),
        Command::Bridge(args) => node::stop_flag().and_then(|stop| {
            seam_bench::bridge::run_bridge(&args, &stop, &mut std::io::stdout().lock()).map(|_| ())
        }),
        Command::Ping {
            transport,
            size,
            iterations,
            warmup,
            wait,
            output,
            no_floor,
        } => {
            let plan = PingPlan {
                transports: transport.iter().map(|t| expand_transport(t)).collect(),
                sizes: size,
                iterations,
                warmup,
                wait,
                floor: !no_floor,
            };
            let total = plan.transports.len() * plan.sizes.len()
                + if plan.floor {
                    plan.transports
                        .iter()
                        .filter(|t| *t == "shm" || t.starts_with("shm?"))
                        .count()
                        * plan.sizes.len()
                } else {
                    0
                };
            eprintln!(
                "seam ping: {iterations} timed round trips per row after {warmup} warm-up, one-way = round trip / 2, {} cores",
                std::thread::available_parallelism().map_or(0, |n| n.get())
            );
            ping::run(&plan, progress(total))
                .map(|rows| output.rows(&rows, ping::document))
                .map_err(|e| e.to_string())
        }
        Command::Ops {
            transport,
            batch,
            acks,
            rounds,
            warmup,
            wait,
            output,
        } => {
            let mut acks: Vec<bool> = acks.iter().map(|&a| a == cli::AckMode::On).collect();
            acks.dedup();
            let plan = OpsPlan {
                transports: transport.iter().map(|t| expand_transport(t)).collect(),
                batches: batch,
                acks,
                rounds,
                warmup,
                wait,
            };
            let total = plan.transports.len() * plan.batches.len() * plan.acks.len();
            eprintln!(
                "seam ops: {rounds} timed frames per row after {warmup} warm-up, one frame in flight"
            );
            ops::run(&plan, progress(total)).map(|rows| output.rows(&rows, ops::document))
        }
        Command::Scene { files } => files.iter().try_for_each(|file| {
            let scene = seam_bench::scene::load(file).map_err(|e| e.to_string())?;
            let entities: u64 = scene.entities.iter().map(|e| e.copies()).sum();
            println!(
                "{}: scene {:?}: {} clusters, {entities} entities, {} events, {} ticks of {:.4} s",
                file.display(),
                scene.name,
                scene.clusters.len(),
                scene.events.len(),
                scene.ticks,
                scene.dt
            );
            Ok(())
        }),
        Command::OpsOwner {
            transport,
            events,
            ack,
            wait,
        } => ops::run_owner(&transport, &events, &ack, wait),
        Command::PingPeer {
            transport,
            ping,
            pong,
            count,
            wait,
        } => ping::run_peer(&transport, &ping, &pong, count, wait),
        Command::PingFloorPeer {
            ping,
            pong,
            size,
            count,
        } => ping::run_floor_peer(&ping, &pong, size, count),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("seam: {e}");
            ExitCode::FAILURE
        }
    }
}
