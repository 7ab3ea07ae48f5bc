//! Frames in: everything the transport holds taken into the inbox, with malformed, replayed and
//! implausible frames counted and dropped, and each sender's liveness noted.

use std::time::Duration;

use super::{Cluster, Phase};
use crate::clock::monotonic_ns;
use crate::error::ClusterError;
use crate::events::{ClusterEvent, FrameRefusal};
use crate::inbox::{Frame, FrameKind, Refused, decode_frame};
use crate::neighbours::Incarnation;

impl Cluster {
    /// Waits up to `timeout` for a frame to arrive, sleeping on the transport's wake-up rather
    /// than spinning, and keeps it (with anything else that has arrived) for the next tick.
    /// Returns whether anything arrived. Free-running pods call this between ticks, so frames
    /// are taken off the transport as they come and stamped "received" when they arrive.
    pub fn wait(&mut self, timeout: Duration) -> Result<bool, ClusterError> {
        self.free_running = true;
        let Some(message) = self.transport.receive_timeout(timeout)? else {
            return Ok(false);
        };
        let cpu = self.phases.now();
        let received_ns = monotonic_ns();
        let frame = decode_frame(&message);
        self.take_in(frame, received_ns);
        self.drain()?;
        self.phases.add_since(Phase::Receive, cpu);
        Ok(true)
    }

    /// Moves everything the transport holds into the inbox.
    pub(super) fn drain(&mut self) -> Result<(), ClusterError> {
        while let Some(message) = self.transport.try_receive()? {
            let received_ns = monotonic_ns();
            // Decoded straight from the received bytes (on shm, the shared-memory sample).
            let frame = decode_frame(&message);
            self.take_in(frame, received_ns);
        }
        Ok(())
    }

    /// Takes one received frame in: a malformed, implausible or replayed frame is counted and
    /// dropped; the others go to the inbox for the tick that uses them.
    pub(super) fn take_in(&mut self, frame: Result<Frame, Refused>, received_ns: u64) {
        match self.file(frame, received_ns) {
            Ok((from, tick, kind)) => {
                self.events.emit(ClusterEvent::FrameAccepted { from });
                self.heard(from, tick, kind);
            }
            Err((reason, from)) => self.refused(reason, from),
        }
    }

    /// Files a frame in the inbox; returns its sender, tick and kind, or why it was refused.
    fn file(
        &mut self,
        frame: Result<Frame, Refused>,
        received_ns: u64,
    ) -> Result<(seam_sim::wire::ClusterId, u64, FrameKind), Refused> {
        let frame = frame?;
        let (from, tick, kind) = (frame.from(), frame.tick(), frame.kind());
        let refuse = |reason| Err((reason, Some(from)));
        match self.neighbours.incarnation(from, frame.incarnation()) {
            Incarnation::Stale => return refuse(FrameRefusal::StaleIncarnation),
            Incarnation::Restarted => self.restarted(from, frame.incarnation()),
            Incarnation::Current => {}
        }
        let mine = self.sim.tick();
        if self
            .neighbours
            .implausible(&self.config, from, tick, mine, self.host_ns)
        {
            return refuse(FrameRefusal::Implausible);
        }
        if self.neighbours.replayed(from, tick, kind) {
            return refuse(FrameRefusal::Replayed);
        }
        if !self.config.neighbours.contains(&from) {
            return refuse(FrameRefusal::WrongSender);
        }
        let kept = match frame {
            Frame::Replication(mut frame) => {
                if !self.keys.read(&mut frame) {
                    self.events.emit(ClusterEvent::KeyframeMissed { from });
                }
                if self.free_running {
                    self.inbox.add_replication_newest(frame)
                } else {
                    self.inbox.add_replication(frame)
                }
            }
            Frame::Events(frame) => self.inbox.add_events(frame, received_ns),
        };
        if kept {
            Ok((from, tick, kind))
        } else {
            refuse(FrameRefusal::Replayed)
        }
    }

    /// A new pod of `neighbour` is heard: what its predecessor sent and is still held goes, and
    /// its frames count from now on (the predecessor's are refused as stale).
    fn restarted(&mut self, neighbour: seam_sim::wire::ClusterId, incarnation: u64) {
        self.inbox.forget(neighbour);
        self.keys.forget(neighbour);
        tracing::info!(
            cluster = %self.config.label(self.config.cluster_id),
            neighbour = %self.config.label(neighbour),
            incarnation,
            "a new pod of the neighbour is heard: its earlier pod's frames are refused from now on"
        );
    }

    /// Notes a frame from `neighbour` tagged `tick`; a neighbour back from the dead gets back
    /// what was adopted from it.
    fn heard(&mut self, neighbour: seam_sim::wire::ClusterId, tick: u64, kind: FrameKind) {
        let now = self.sim.tick();
        if !self
            .neighbours
            .heard(neighbour, tick, kind, now, self.host_ns)
        {
            return;
        }
        self.events
            .emit(ClusterEvent::NeighbourRejoined { neighbour });
        let returned = self.stats().entities_returned;
        self.custody
            .return_to(neighbour, &self.sim, &mut self.handoffs, &mut self.events);
        tracing::info!(
            cluster = %self.config.label(self.config.cluster_id),
            neighbour = %self.config.label(neighbour),
            returned = self.stats().entities_returned - returned,
            "neighbour back: what was adopted from it is handed back"
        );
    }
}
