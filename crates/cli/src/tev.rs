//! `--display-server HOST:PORT`: streams the image to a running tev
//! (<https://github.com/Tom94/tev>) after every pass, as pbrt-v4's
//! `--display-server` does. The render never depends on it: when tev cannot
//! be reached, or the connection is lost, one line says so and the render
//! goes on without it.
//!
//! tev's TCP protocol: every packet is its length (u32, little-endian, the
//! length field included), a type byte and a payload; strings end in a NUL,
//! integers are little-endian. Two packets are used here:
//! - create image (type 4): grab focus (u8), name, width and height (i32),
//!   channel count (i32), the channel names;
//! - update image, version 3 (type 6): grab focus, name, channel count, the
//!   channel names, the tile's x, y, width and height (i32), each channel's
//!   offset and then each channel's stride (i64, in floats) into the data
//!   that follows (f32), here channels interleaved pixel by pixel.
//!
//! The beauty image is sent as `R`, `G`, `B`; AOVs as the EXR names them
//! (`albedo.R`, `normal.X`, `depth.Z`, `variance.G`, ...), which tev shows as
//! layers. Tiles are at most [`TILE`] pixels on a side, so that a packet
//! stays small.

use penumbra_render::film::Film;
use std::io::Write;
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::time::Duration;

/// The packet types used (tev's `IpcPacket::EType`).
pub const CREATE_IMAGE: u8 = 4;
pub const UPDATE_IMAGE_V3: u8 = 6;
/// The largest tile side sent in one update packet.
pub const TILE: u32 = 128;
/// How long a connection attempt and a blocked write may take.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(3);
const WRITE_TIMEOUT: Duration = Duration::from_secs(10);

/// Checks `--display-server`'s value: `HOST:PORT` (an IPv6 host in brackets).
pub fn parse_address(s: &str) -> Result<String, String> {
    let bad = || format!("'{s}' is not of the form HOST:PORT (e.g. localhost:14158, tev's default port)");
    let (host, port) = s.rsplit_once(':').ok_or_else(bad)?;
    if host.is_empty() || port.parse::<u16>().is_err() {
        return Err(bad());
    }
    Ok(s.to_string())
}

/// A packet under construction: the length is filled in by [`Packet::finish`].
struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8) -> Packet {
        Packet(vec![0, 0, 0, 0, kind])
    }
    fn u8(&mut self, v: u8) -> &mut Self {
        self.0.push(v);
        self
    }
    fn i32(&mut self, v: i32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn i64(&mut self, v: i64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn str(&mut self, s: &str) -> &mut Self {
        // NUL ends a string: a name holding one is cut there.
        self.0.extend(s.bytes().take_while(|&b| b != 0));
        self.0.push(0);
        self
    }
    fn finish(&mut self) -> Vec<u8> {
        let n = self.0.len() as u32;
        self.0[..4].copy_from_slice(&n.to_le_bytes());
        std::mem::take(&mut self.0)
    }
}

/// The create-image packet for an image of `width` x `height` pixels.
pub fn create_image(name: &str, width: u32, height: u32, channels: &[&str]) -> Vec<u8> {
    let mut p = Packet::new(CREATE_IMAGE);
    p.u8(1).str(name).i32(width as i32).i32(height as i32).i32(channels.len() as i32);
    for c in channels {
        p.str(c);
    }
    p.finish()
}

/// The update packets (one per tile, row by row) that send all of an image
/// of `width` pixels a row, given as planes: `planes[c][y * width + x]`.
pub fn update_image(name: &str, width: u32, channels: &[&str], planes: &[&[f32]]) -> Vec<Vec<u8>> {
    assert_eq!(channels.len(), planes.len());
    let n = channels.len();
    let height = if width == 0 { 0 } else { planes.first().map_or(0, |p| p.len() as u32 / width) };
    let mut out = Vec::new();
    for y0 in (0..height).step_by(TILE as usize) {
        for x0 in (0..width).step_by(TILE as usize) {
            let (w, h) = (TILE.min(width - x0), TILE.min(height - y0));
            let mut p = Packet::new(UPDATE_IMAGE_V3);
            p.u8(0).str(name).i32(n as i32);
            for c in channels {
                p.str(c);
            }
            p.i32(x0 as i32).i32(y0 as i32).i32(w as i32).i32(h as i32);
            for c in 0..n {
                p.i64(c as i64);
            }
            for _ in 0..n {
                p.i64(n as i64);
            }
            p.0.reserve((w * h) as usize * n * 4);
            for y in y0..y0 + h {
                for x in x0..x0 + w {
                    let i = (y * width + x) as usize;
                    for plane in planes {
                        p.0.extend_from_slice(&plane[i].to_le_bytes());
                    }
                }
            }
            out.push(p.finish());
        }
    }
    out
}

/// The film's channels as tev gets them: the beauty image, then its layers.
pub fn channels(film: &Film) -> Vec<(String, Vec<f32>)> {
    let rgb = film.develop();
    let mut out: Vec<(String, Vec<f32>)> =
        ["R", "G", "B"].iter().enumerate().map(|(c, n)| (n.to_string(), rgb.iter().map(|p| p[c]).collect())).collect();
    out.extend(crate::layers::channels(film, false));
    out
}

/// A connection to tev, or nothing once it is lost.
pub struct Display {
    stream: Option<TcpStream>,
    address: String,
    name: String,
    created: bool,
}

impl Display {
    /// Connects to tev at `address`, or prints one line saying why not and
    /// returns a display that does nothing. `name` is the image's name in tev.
    pub fn connect(address: &str, name: &str) -> Display {
        let mut d = Display { stream: None, address: address.to_string(), name: name.to_string(), created: false };
        match open(address) {
            Ok(s) => d.stream = Some(s),
            Err(e) => eprintln!("--display-server: cannot connect to {address} ({e}): rendering without it"),
        }
        d
    }

    /// Whether the connection is up.
    pub fn connected(&self) -> bool {
        self.stream.is_some()
    }

    /// Sends the film's current image (all of it); the first call creates
    /// the image in tev.
    pub fn show(&mut self, film: &Film) {
        if self.stream.is_none() {
            return;
        }
        let ch = channels(film);
        let names: Vec<&str> = ch.iter().map(|(n, _)| n.as_str()).collect();
        let planes: Vec<&[f32]> = ch.iter().map(|(_, v)| v.as_slice()).collect();
        let mut packets = Vec::new();
        if !self.created {
            packets.push(create_image(&self.name, film.width, film.height, &names));
        }
        packets.extend(update_image(&self.name, film.width, &names, &planes));
        let stream = self.stream.as_mut().unwrap();
        match packets.iter().try_for_each(|p| stream.write_all(p)).and_then(|_| stream.flush()) {
            Ok(()) => self.created = true,
            Err(e) => {
                eprintln!(
                    "--display-server: lost the connection to {} ({e}): rendering goes on without it",
                    self.address
                );
                self.stream = None;
            }
        }
    }
}

/// Connects to the first of `address`'s resolved addresses that answers.
fn open(address: &str) -> std::io::Result<TcpStream> {
    let addrs: Vec<SocketAddr> = address.to_socket_addrs()?.collect();
    let mut last = std::io::Error::new(std::io::ErrorKind::NotFound, "the host name resolves to no address");
    for a in addrs {
        match TcpStream::connect_timeout(&a, CONNECT_TIMEOUT) {
            Ok(s) => {
                s.set_nodelay(true)?;
                s.set_write_timeout(Some(WRITE_TIMEOUT))?;
                return Ok(s);
            }
            Err(e) => last = e,
        }
    }
    Err(last)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u32_at(b: &[u8], i: usize) -> u32 {
        u32::from_le_bytes(b[i..i + 4].try_into().unwrap())
    }

    #[test]
    fn create_packet_layout() {
        let p = create_image("a.exr", 3, 2, &["R", "G"]);
        let mut want = vec![0u8; 4];
        want.extend([4, 1]);
        want.extend(b"a.exr\0");
        want.extend(3i32.to_le_bytes());
        want.extend(2i32.to_le_bytes());
        want.extend(2i32.to_le_bytes());
        want.extend(b"R\0G\0");
        let n = want.len() as u32;
        want[..4].copy_from_slice(&n.to_le_bytes());
        assert_eq!(p, want);
    }

    #[test]
    fn update_packets_tile_the_image_and_interleave_channels() {
        let (w, h) = (TILE + 5, 3);
        let r: Vec<f32> = (0..w * h).map(|i| i as f32).collect();
        let g: Vec<f32> = (0..w * h).map(|i| -(i as f32)).collect();
        let ps = update_image("x", w, &["R", "G"], &[&r, &g]);
        assert_eq!(ps.len(), 2, "two tiles across, one down");
        for (k, p) in ps.iter().enumerate() {
            assert_eq!(u32_at(p, 0) as usize, p.len());
            assert_eq!(p[4], UPDATE_IMAGE_V3);
            // grab focus, "x\0", count, "R\0G\0": the tile then starts at 14.
            let head = 5 + 1 + 2 + 4 + 4;
            let (x0, tw) = (u32_at(p, head), u32_at(p, head + 8));
            assert_eq!((x0, tw), if k == 0 { (0, TILE) } else { (TILE, 5) });
            assert_eq!(u32_at(p, head + 4), 0);
            assert_eq!(u32_at(p, head + 12), h);
            let data = &p[head + 16 + 2 * 8 * 2..];
            assert_eq!(data.len(), (tw * h) as usize * 2 * 4);
            // The last pixel of the tile: R then G.
            let last = |c: usize| f32::from_le_bytes(data[data.len() - 8 + 4 * c..][..4].try_into().unwrap());
            let i = ((h - 1) * w + x0 + tw - 1) as f32;
            assert_eq!((last(0), last(1)), (i, -i));
        }
    }

    #[test]
    fn addresses() {
        assert!(parse_address("localhost:14158").is_ok());
        assert!(parse_address("[::1]:14158").is_ok());
        for bad in ["localhost", ":14158", "host:", "host:99999", "host:x"] {
            assert!(parse_address(bad).is_err(), "{bad}");
        }
    }
}
