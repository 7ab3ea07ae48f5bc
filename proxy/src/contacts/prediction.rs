//! An impulse this cluster routes to an entity's owner, shown at once on its own proxy of it.
//!
//! A routed write lands at its owner a tick after game code made it. Meanwhile this world
//! would simulate its proxy as if the write had not happened: a blast that pushes this
//! cluster's bodies now and a neighbour's a tick later drives the pushed bodies into proxies
//! still standing, where one world pushes them all apart together, and each world solves a
//! contact the other does not see (momentum made from nothing).
//!
//! > While a proxy is **coupled** (simulated here for the step, see `seam_sim::coupling`), an
//! > impulse game code routed to its owner is added to it here too, in the step the write was
//! > made, until the owner's next replicated state of the entity sets the proxy.
//!
//! A proxy that is not coupled takes nothing (nothing here simulates it); one coupled after
//! the write, before that state, takes it then. A prediction whose state never comes (the
//! owner stalled) is dropped [`MAX_PREDICTED_TICKS`] after the next frame was due.
//!
//! Why only until the next state, though in lock-step that state (of the step the write was
//! made) does not carry the write yet: adding it again to that state as well — the proxy then
//! moving as its owner's body does the step after — was measured worse where bodies rest
//! against each other. Lock-step `seam compare`, Fixed proxies, a frame every tick: without
//! prediction `grid` 0.0030–0.0034 of Σm|v| momentum error and `seam-stack` 4.6 cm RMS; until
//! the next state 0.0019–0.0027 (nine runs) and 4.0 cm; once more after it 0.0014–0.0017 and 5.7 cm (the
//! re-kicked proxy stands where the un-kicked state put it, a step's worth of the kick behind
//! the bodies pushed with it, and is driven into them).

use seam_sim::wire::{EntityId, PhysicsOp, RoutedOp};
use seam_sim::{BodyRole, ClusterSim};

/// Ticks past the next frame's due tick a prediction is kept, whatever comes.
pub(crate) const MAX_PREDICTED_TICKS: u64 = 4;

struct Predicted {
    target: EntityId,
    impulse: [f32; 3],
    issued_tick: u64,
    /// Whether the proxy's body moves with it now.
    shown: bool,
}

/// Routed impulses shown on this cluster's coupled proxies of their targets.
#[derive(Default)]
pub(crate) struct Predictions {
    pending: Vec<Predicted>,
}

impl Predictions {
    /// Notes the impulses game code routed at `tick` among `routed` (forwarded ops and
    /// another tick's are not this tick's game code).
    pub(crate) fn routed<'a>(&mut self, routed: impl IntoIterator<Item = &'a RoutedOp>, tick: u64) {
        for r in routed {
            if let PhysicsOp::Impulse { target, impulse } = r.op
                && r.issued_tick == tick
                && !r.forwarded()
            {
                self.pending.push(Predicted {
                    target,
                    impulse,
                    issued_tick: tick,
                    shown: false,
                });
            }
        }
    }

    /// Notes the impulses a neighbour's game code gave its own bodies at `tick` (from its
    /// exchange frame of that tick): shown on this world's coupled proxies of them as this
    /// cluster's own routed impulses are, so that both worlds step those bodies pushed.
    pub(crate) fn neighbour_wrote(&mut self, writes: &[PhysicsOp], tick: u64) {
        for op in writes {
            if let PhysicsOp::Impulse { target, impulse } = *op {
                self.pending.push(Predicted {
                    target,
                    impulse,
                    issued_tick: tick,
                    shown: false,
                });
            }
        }
    }

    /// The owner's replicated state of `id` has set its proxy: the predictions for it end.
    pub(crate) fn state_applied(&mut self, id: EntityId) {
        if !self.pending.is_empty() {
            self.pending.retain(|p| p.target != id);
        }
    }

    /// Adds each prediction to its proxy if the proxy is coupled and does not move with it yet
    /// (call after coupling, before the step); forgets those past their time or whose target
    /// is no longer a proxy. Returns how many impulses it added.
    pub(crate) fn show(&mut self, sim: &mut ClusterSim, now: u64, interval: u64) -> u64 {
        let me = sim.config().cluster_id;
        let mut added = 0;
        self.pending.retain_mut(|p| {
            let Some(info) = sim.info(p.target) else {
                return false;
            };
            if info.owner == me || now > p.issued_tick + interval + MAX_PREDICTED_TICKS {
                return false;
            }
            if info.role != BodyRole::Dynamic {
                // Set back to its mode's role by coupling: moves with the replicated state.
                p.shown = false;
            } else if !p.shown {
                let op = PhysicsOp::Impulse {
                    target: p.target,
                    impulse: p.impulse,
                };
                p.shown = sim.apply_op(&op).is_ok();
                added += u64::from(p.shown);
            }
            true
        });
        added
    }
}
