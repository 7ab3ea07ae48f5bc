//! A RESP2 reader for what a subscribed Redis connection receives: arrays of at most four
//! bulk strings or integers (`message`, `pmessage`, subscription confirmations, `pong`), plus
//! simple strings and errors. It borrows from the read buffer and never allocates.

/// One element of a reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Item<'a> {
    Bulk(&'a [u8]),
    Int(i64),
    Simple(&'a [u8]),
    Error(&'a [u8]),
    Nil,
}

/// One reply: a top-level item, or an array of up to [`MAX_ITEMS`] items.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Frame<'a> {
    pub(super) items: [Item<'a>; MAX_ITEMS],
    pub(super) len: usize,
    pub(super) is_array: bool,
}

const MAX_ITEMS: usize = 4;

/// Why a buffer does not hold a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum RespError {
    /// The bytes are not RESP2 as a subscribed connection sees it; the stream is unusable.
    Protocol(&'static str),
    /// A bulk string is longer than allowed; skip `skip` bytes from the frame's start to pass it.
    TooLarge { skip: usize },
}

/// Parses one frame at the start of `buf`. `Ok(None)`: more bytes are needed.
/// `Ok(Some((frame, used)))`: the frame and how many bytes it took.
pub(super) fn parse(buf: &[u8], max_bulk: usize) -> Result<Option<(Frame<'_>, usize)>, RespError> {
    let mut pos = 0;
    let Some(first) = item(buf, &mut pos, max_bulk)? else {
        return Ok(None);
    };
    let mut frame = Frame {
        items: [Item::Nil; MAX_ITEMS],
        len: 1,
        is_array: false,
    };
    match first {
        Header::Item(item) => frame.items[0] = item,
        Header::Array(count) => {
            if count > MAX_ITEMS {
                return Err(RespError::Protocol("array longer than a pub/sub reply"));
            }
            frame.is_array = true;
            frame.len = count;
            for slot in frame.items.iter_mut().take(count) {
                match item(buf, &mut pos, max_bulk)? {
                    None => return Ok(None),
                    Some(Header::Item(item)) => *slot = item,
                    Some(Header::Array(_)) => {
                        return Err(RespError::Protocol("nested array in a pub/sub reply"));
                    }
                }
            }
        }
    }
    Ok(Some((frame, pos)))
}

enum Header<'a> {
    Item(Item<'a>),
    Array(usize),
}

/// Reads one item or array header at `*pos`, advancing it. `Ok(None)`: incomplete.
fn item<'a>(
    buf: &'a [u8],
    pos: &mut usize,
    max_bulk: usize,
) -> Result<Option<Header<'a>>, RespError> {
    if buf.get(*pos..*pos + 2) == Some(&b"\r\n"[..]) {
        // No type byte: not a reply that more bytes could complete.
        return Err(RespError::Protocol("empty line"));
    }
    let Some(line) = line(buf, *pos) else {
        return Ok(None);
    };
    let (kind, body) = (buf[*pos], &buf[*pos + 1..line]);
    let after_line = line + 2;
    let header = match kind {
        b'+' => Header::Item(Item::Simple(body)),
        b'-' => Header::Item(Item::Error(body)),
        b':' => Header::Item(Item::Int(number(body)?)),
        b'*' => match number(body)? {
            n if n < 0 => Header::Item(Item::Nil),
            n => {
                Header::Array(usize::try_from(n).map_err(|_| RespError::Protocol("array length"))?)
            }
        },
        b'$' => {
            let len = number(body)?;
            if len < 0 {
                Header::Item(Item::Nil)
            } else {
                let len = usize::try_from(len).map_err(|_| RespError::Protocol("bulk length"))?;
                if len > max_bulk {
                    return Err(RespError::TooLarge {
                        skip: after_line.saturating_add(len).saturating_add(2),
                    });
                }
                let end = after_line + len;
                if buf.len() < end + 2 {
                    return Ok(None);
                }
                if &buf[end..end + 2] != b"\r\n" {
                    return Err(RespError::Protocol("bulk string not closed by CRLF"));
                }
                *pos = end + 2;
                return Ok(Some(Header::Item(Item::Bulk(&buf[after_line..end]))));
            }
        }
        _ => return Err(RespError::Protocol("unknown RESP type byte")),
    };
    *pos = after_line;
    Ok(Some(header))
}

/// Index of the `\r` that ends the line starting at `from`.
fn line(buf: &[u8], from: usize) -> Option<usize> {
    buf.get(from..)?
        .windows(2)
        .position(|w| w == b"\r\n")
        .map(|at| from + at)
        .filter(|&at| at > from)
}

fn number(body: &[u8]) -> Result<i64, RespError> {
    std::str::from_utf8(body)
        .ok()
        .and_then(|text| text.parse().ok())
        .ok_or(RespError::Protocol("malformed number"))
}

/// What the fuzz target `resp_reader` checks of any input (see `fuzz/`): no panic; a complete
/// reply took at most the input and at most four items, parses the same from exactly its own
/// bytes, and is incomplete (never an error) cut short; an oversized bulk string says to skip
/// past at least its header.
pub(crate) fn fuzz_check(bytes: &[u8]) {
    const MAX_BULK: usize = 64;
    match parse(bytes, MAX_BULK) {
        Ok(Some((frame, used))) => {
            assert!(used > 0 && used <= bytes.len() && frame.len <= MAX_ITEMS);
            assert_eq!(parse(&bytes[..used], MAX_BULK), Ok(Some((frame, used))));
            for cut in [0, used / 2, used - 1] {
                assert_eq!(parse(&bytes[..cut], MAX_BULK), Ok(None), "cut at {cut}");
            }
        }
        Err(RespError::TooLarge { skip }) => assert!(skip > MAX_BULK),
        Ok(None) | Err(RespError::Protocol(_)) => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn message_and_pmessage() {
        let raw = b"*3\r\n$7\r\nmessage\r\n$2\r\nch\r\n$3\r\nabc\r\n";
        let (frame, used) = parse(raw, 100).expect("valid").expect("complete");
        assert_eq!(used, raw.len());
        assert_eq!(frame.len, 3);
        assert_eq!(frame.items[2], Item::Bulk(b"abc"));

        let raw = b"*4\r\n$8\r\npmessage\r\n$2\r\nc*\r\n$2\r\nch\r\n$0\r\n\r\n";
        let (frame, _) = parse(raw, 100).expect("valid").expect("complete");
        assert_eq!(frame.items[1], Item::Bulk(b"c*"));
        assert_eq!(frame.items[3], Item::Bulk(b""));
    }

    #[test]
    fn confirmation_and_errors() {
        let raw = b"*3\r\n$9\r\nsubscribe\r\n$2\r\nch\r\n:1\r\n";
        let (frame, _) = parse(raw, 100).expect("valid").expect("complete");
        assert_eq!(frame.items[2], Item::Int(1));
        let (frame, _) = parse(b"-ERR nope\r\n", 100)
            .expect("valid")
            .expect("complete");
        assert_eq!(frame.items[0], Item::Error(b"ERR nope"));
        assert!(!frame.is_array);
    }

    #[test]
    fn every_prefix_is_incomplete_not_an_error() {
        let raw = b"*3\r\n$7\r\nmessage\r\n$2\r\nch\r\n$3\r\nabc\r\n";
        for cut in 0..raw.len() {
            assert_eq!(parse(&raw[..cut], 100), Ok(None), "cut at {cut}");
        }
    }

    #[test]
    fn oversized_bulk_says_how_much_to_skip() {
        let raw = b"*3\r\n$7\r\nmessage\r\n$2\r\nch\r\n$10\r\n";
        assert_eq!(
            parse(raw, 8),
            Err(RespError::TooLarge {
                skip: raw.len() + 12
            })
        );
    }

    #[test]
    fn garbage_is_a_protocol_error() {
        assert!(matches!(
            parse(b"hello\r\n", 100),
            Err(RespError::Protocol(_))
        ));
        assert!(matches!(parse(b"*9\r\n", 100), Err(RespError::Protocol(_))));
        assert!(matches!(parse(b"$x\r\n", 100), Err(RespError::Protocol(_))));
        // An empty line is not the start of a reply that more bytes could complete.
        assert!(matches!(
            parse(b"\r\n+OK\r\n", 100),
            Err(RespError::Protocol(_))
        ));
        assert!(matches!(
            parse(b"*2\r\n\r\n", 100),
            Err(RespError::Protocol(_))
        ));
    }
}
