//! What the subscribed socket brings: pub/sub replies parsed in place, messages checked
//! against their envelope, and the message returned last.

use std::ops::Range;

use crate::envelope::{Envelope, Intake};
use crate::error::ReceiveError;
use crate::{Message, Origin};

use super::RedisTransport;
use super::resp::{self, Frame, Item, RespError};

pub(super) struct EarlyMessage {
    pub(super) channel: String,
    pub(super) pattern: Option<String>,
    pub(super) payload: Range<usize>,
    pub(super) wire: Vec<u8>,
    pub(super) origin: Origin,
}

/// Where the last returned message lives.
pub(super) enum Current {
    Buffered {
        channel: Range<usize>,
        pattern: Option<Range<usize>>,
        payload: Range<usize>,
        origin: Origin,
    },
    Early(EarlyMessage),
}

/// What a parsed reply is.
pub(super) enum Reply<'a> {
    Message {
        channel: &'a [u8],
        pattern: Option<&'a [u8]>,
        wire: &'a [u8],
    },
    Confirmation {
        kind: &'a [u8],
        channel: &'a [u8],
    },
    ServerError(&'a [u8]),
    Other,
}

pub(super) fn classify<'a>(frame: &Frame<'a>) -> Reply<'a> {
    let bulk = |i: usize| match frame.items[i] {
        Item::Bulk(bytes) => Some(bytes),
        _ => None,
    };
    if !frame.is_array {
        return match frame.items[0] {
            Item::Error(text) => Reply::ServerError(text),
            _ => Reply::Other,
        };
    }
    match (frame.len, bulk(0)) {
        (3, Some(b"message" | b"smessage")) => match (bulk(1), bulk(2)) {
            (Some(channel), Some(wire)) => Reply::Message {
                channel,
                pattern: None,
                wire,
            },
            _ => Reply::Other,
        },
        (4, Some(b"pmessage")) => match (bulk(1), bulk(2), bulk(3)) {
            (Some(pattern), Some(channel), Some(wire)) => Reply::Message {
                channel,
                pattern: Some(pattern),
                wire,
            },
            _ => Reply::Other,
        },
        (3, Some(kind)) => match bulk(1) {
            Some(channel) => Reply::Confirmation { kind, channel },
            None => Reply::Other,
        },
        _ => Reply::Other,
    }
}

/// Checks a message's envelope and counts it; returns the payload range inside `wire` if valid.
pub(super) fn accept(
    intake: &mut Intake,
    channel: &[u8],
    wire: &[u8],
) -> Option<(Range<usize>, Origin)> {
    match std::str::from_utf8(channel).ok().zip(Envelope::split(wire)) {
        Some((channel, (envelope, payload))) => {
            let key = intake.channel_key(channel);
            intake
                .accept(key, channel, &envelope, payload)
                .then(|| (range_in(wire, payload), envelope.origin()))
        }
        None => {
            intake.malformed();
            None
        }
    }
}

/// Where a pub/sub message's channel, pattern and payload lie in the socket's buffer.
type Ranges = (Range<usize>, Option<Range<usize>>, Range<usize>);

/// Offset range of `part` inside `whole` (`part` must be a sub-slice of `whole`).
pub(super) fn range_in(whole: &[u8], part: &[u8]) -> Range<usize> {
    let start = part.as_ptr() as usize - whole.as_ptr() as usize;
    start..start + part.len()
}

impl RedisTransport {
    /// Moves the next valid message into `self.current`; returns whether there was one.
    pub(super) fn advance(&mut self) -> Result<bool, ReceiveError> {
        match self.advance_connected() {
            Err(_) if self.config.reconnect => {
                self.went_down();
                Ok(false)
            }
            result => result,
        }
    }

    pub(super) fn advance_connected(&mut self) -> Result<bool, ReceiveError> {
        self.current = None;
        if self.config.reconnect && !self.up() {
            return Ok(false);
        }
        if self.take_early() {
            return Ok(true);
        }
        let (max_bulk, frame_limit) = (self.max_bulk(), self.frame_limit());
        loop {
            if self.discard > 0 {
                self.skip_discarded();
                if self.discard > 0 {
                    if self.fill_more(frame_limit)? {
                        continue;
                    }
                    return Ok(false);
                }
            }
            match self.parse_next(max_bulk) {
                Ok(Some((used, message))) => {
                    self.socket.consume(used);
                    if let Some(message) = message
                        && self.take_buffered(message)
                    {
                        return Ok(true);
                    }
                }
                Ok(None) => {
                    if !self.fill_more(frame_limit)? {
                        return Ok(false);
                    }
                }
                Err(RespError::TooLarge { skip }) => {
                    self.intake.malformed();
                    self.discard = skip;
                }
                Err(RespError::Protocol(what)) => {
                    return Err(self.disconnected(format!("protocol error: {what}")));
                }
            }
        }
    }

    fn disconnected(&self, reason: String) -> ReceiveError {
        ReceiveError::Disconnected {
            addr: self.addr.clone(),
            reason,
        }
    }

    /// Reads more from the socket; `false` when nothing more has come.
    fn fill_more(&mut self, frame_limit: usize) -> Result<bool, ReceiveError> {
        self.socket
            .fill(None, frame_limit)
            .map_err(|e| self.disconnected(e.to_string()))
    }

    /// Makes the first valid message received early (while a command waited for its reply)
    /// the current one; returns whether there was one.
    fn take_early(&mut self) -> bool {
        while let Some(mut early) = self.early.pop_front() {
            if let Some((payload, origin)) =
                accept(&mut self.intake, early.channel.as_bytes(), &early.wire)
            {
                early.payload = payload;
                early.origin = origin;
                self.current = Some(Current::Early(early));
                return true;
            }
        }
        false
    }

    /// Parses the next reply in the socket's buffer: the bytes it used, and where a pub/sub
    /// message's channel, pattern and payload lie in the buffer (`None` for another reply).
    fn parse_next(
        &mut self,
        max_bulk: usize,
    ) -> Result<Option<(usize, Option<Ranges>)>, RespError> {
        let Some((frame, used)) = resp::parse(self.socket.unparsed(), max_bulk)? else {
            return Ok(None);
        };
        let buf = &self.socket.buf;
        let message = match classify(&frame) {
            Reply::Message {
                channel,
                pattern,
                wire,
            } => Some((
                range_in(buf, channel),
                pattern.map(|p| range_in(buf, p)),
                range_in(buf, wire),
            )),
            // Not asked for (an asked one is read by `command`): a Redis Cluster node no
            // longer serves the channel's slot.
            Reply::Confirmation {
                kind: b"sunsubscribe",
                channel,
            } => {
                self.dropped_by_server
                    .push(String::from_utf8_lossy(channel).into_owned());
                None
            }
            _ => None,
        };
        Ok(Some((used, message)))
    }

    /// Makes a message in the buffer the current one if it is a valid seam envelope; returns
    /// whether it was.
    fn take_buffered(&mut self, (channel, pattern, wire): Ranges) -> bool {
        let buf = &self.socket.buf;
        let Some((payload, origin)) =
            accept(&mut self.intake, &buf[channel.clone()], &buf[wire.clone()])
        else {
            return false;
        };
        let payload = wire.start + payload.start..wire.start + payload.end;
        self.current = Some(Current::Buffered {
            channel,
            pattern,
            payload,
            origin,
        });
        true
    }

    pub(crate) fn current_message(&self) -> Option<Message<'_>> {
        // Channel names were checked as UTF-8 in `accept`; patterns come from the server as sent.
        fn text(bytes: &[u8]) -> &str {
            std::str::from_utf8(bytes).unwrap_or("")
        }
        match self.current.as_ref()? {
            Current::Buffered {
                channel,
                pattern,
                payload,
                origin,
            } => {
                let buf = &self.socket.buf;
                Some(Message {
                    channel: text(&buf[channel.clone()]),
                    pattern: pattern.clone().map(|p| text(&buf[p])),
                    payload: &buf[payload.clone()],
                    origin: *origin,
                    signer: self.intake.checked_signer(origin),
                })
            }
            Current::Early(early) => Some(Message {
                channel: &early.channel,
                pattern: early.pattern.as_deref(),
                payload: &early.wire[early.payload.clone()],
                origin: early.origin,
                signer: self.intake.checked_signer(&early.origin),
            }),
        }
    }
}
