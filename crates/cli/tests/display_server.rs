//! `--display-server`: a small tev-protocol server of this test's own on
//! loopback receives what a render streams and checks it: the create-image
//! packet (name, size, channels), one full update per pass, and the last
//! pass's pixels bitwise equal to the EXR the render writes, AOVs included.
//! A connection that is refused or lost is reported once and the render
//! goes on. (tev itself is not installed here: it needs a display and GPU.)

use std::io::Read;
use std::net::{TcpListener, TcpStream};
use std::thread;

use crate::common;

/// One parsed packet.
#[derive(Debug)]
enum Packet {
    Create { name: String, width: i32, height: i32, channels: Vec<String> },
    Update { name: String, channels: Vec<String>, x: i32, y: i32, w: i32, h: i32, data: Vec<f32> },
}

/// Reads a tev packet stream until the peer closes it.
fn read_packets(mut s: TcpStream) -> Vec<Packet> {
    let mut all = Vec::new();
    s.read_to_end(&mut all).unwrap();
    let mut out = Vec::new();
    let mut at = 0;
    while at < all.len() {
        let len = u32::from_le_bytes(all[at..at + 4].try_into().unwrap()) as usize;
        assert!(len >= 5 && at + len <= all.len(), "packet length {len} at byte {at} of {}", all.len());
        out.push(parse(&all[at + 4..at + len]));
        at += len;
    }
    out
}

struct Cursor<'a>(&'a [u8]);
impl Cursor<'_> {
    fn u8(&mut self) -> u8 {
        let v = self.0[0];
        self.0 = &self.0[1..];
        v
    }
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let v = self.0[..N].try_into().unwrap();
        self.0 = &self.0[N..];
        v
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take())
    }
    fn i64(&mut self) -> i64 {
        i64::from_le_bytes(self.take())
    }
    fn str(&mut self) -> String {
        let n = self.0.iter().position(|&b| b == 0).expect("NUL-terminated string");
        let s = String::from_utf8(self.0[..n].to_vec()).unwrap();
        self.0 = &self.0[n + 1..];
        s
    }
}

fn parse(b: &[u8]) -> Packet {
    let mut c = Cursor(b);
    match c.u8() {
        4 => {
            assert_eq!(c.u8(), 1, "grab focus on create");
            let name = c.str();
            let (width, height, n) = (c.i32(), c.i32(), c.i32());
            let channels = (0..n).map(|_| c.str()).collect();
            assert!(c.0.is_empty(), "trailing bytes in create");
            Packet::Create { name, width, height, channels }
        }
        6 => {
            c.u8();
            let name = c.str();
            let n = c.i32() as usize;
            let channels: Vec<String> = (0..n).map(|_| c.str()).collect();
            let (x, y, w, h) = (c.i32(), c.i32(), c.i32(), c.i32());
            let offsets: Vec<i64> = (0..n).map(|_| c.i64()).collect();
            let strides: Vec<i64> = (0..n).map(|_| c.i64()).collect();
            let floats: Vec<f32> = c.0.chunks_exact(4).map(|q| f32::from_le_bytes(q.try_into().unwrap())).collect();
            assert_eq!(c.0.len() % 4, 0);
            // Planes, by tev's rule: channel k of pixel i is floats[offset_k + i * stride_k].
            let px = (w * h) as usize;
            let mut data = vec![0.0; px * n];
            for k in 0..n {
                for i in 0..px {
                    data[k * px + i] = floats[offsets[k] as usize + i * strides[k] as usize];
                }
            }
            Packet::Update { name, channels, x, y, w, h, data }
        }
        t => panic!("unexpected packet type {t}"),
    }
}

/// A server that accepts one connection and returns its packets.
fn serve() -> (String, thread::JoinHandle<Vec<Packet>>) {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = l.local_addr().unwrap().to_string();
    (addr, thread::spawn(move || read_packets(l.accept().unwrap().0)))
}

/// `penumbra render` of the bundled Cornell box to `out`, streamed to
/// `addr`, with `args`; it must succeed. Returns its stderr.
fn render_to(addr: &str, out: &std::path::Path, args: &[&str]) -> String {
    let o = common::ok(
        common::bin()
            .arg("render")
            .arg(common::cornell())
            .arg("-o")
            .arg(out)
            .args(args)
            .args(["--quiet", "--display-server", addr])
            .output()
            .unwrap(),
    );
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn streams_every_pass_and_the_last_equals_the_exr() {
    let d = common::tmpdir("tev", "stream");
    let exr = d.join("box.exr");
    let (addr, server) = serve();
    // 160 x 160: tiles of 128 leave partial tiles on both axes. 8 spp: passes of 1, 1, 2, 4.
    let err = render_to(&addr, &exr, &["-D", "res=160", "--spp", "8", "--seed", "5", "--aov", "albedo,depth"]);
    assert!(!err.contains("--display-server"), "{err}");
    let packets = server.join().unwrap();

    let Packet::Create { name, width, height, channels } = &packets[0] else {
        panic!("first packet: {:?}", packets[0])
    };
    assert_eq!((name.as_str(), *width, *height), ("box.exr", 160, 160));
    let want = ["R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "depth.Z"];
    assert_eq!(channels, &want);

    // Every pass covers each pixel once; the image is assembled pass by pass.
    let n = want.len();
    let mut image = vec![vec![f32::NAN; 160 * 160]; n];
    let mut covered = vec![0u32; 160 * 160];
    for p in &packets[1..] {
        let Packet::Update { name: nm, channels: ch, x, y, w, h, data } = p else { panic!("{p:?}") };
        assert_eq!((nm.as_str(), ch.as_slice()), ("box.exr", channels.as_slice()));
        assert!(*w <= 128 && *h <= 128 && x + w <= 160 && y + h <= 160);
        for ty in 0..*h {
            for tx in 0..*w {
                let i = ((y + ty) * 160 + x + tx) as usize;
                covered[i] += 1;
                for (k, plane) in image.iter_mut().enumerate() {
                    plane[i] = data[k * (w * h) as usize + (ty * w + tx) as usize];
                }
            }
        }
    }
    assert!(covered.iter().all(|&c| c == 4), "4 passes, each pixel once a pass: {:?}", &covered[..4]);
    let e = common::read_exr(&exr);
    for (k, c) in want.iter().enumerate() {
        let got: Vec<u32> = image[k].iter().map(|v| v.to_bits()).collect();
        let exr_bits: Vec<u32> = e.ch(c).iter().map(|v| v.to_bits()).collect();
        assert!(got == exr_bits, "channel {c} differs from the EXR");
    }
    let mean_r: f32 = image[0].iter().sum::<f32>() / image[0].len() as f32;
    assert!(mean_r > 0.05, "not a black image: mean R {mean_r}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_lost_connection_is_reported_once_and_the_render_goes_on() {
    let d = common::tmpdir("tev", "lost");
    let png = d.join("box.png");
    // Reads the first packet (the create), then closes.
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = l.local_addr().unwrap().to_string();
    let server = thread::spawn(move || {
        let (mut s, _) = l.accept().unwrap();
        let mut len = [0u8; 4];
        s.read_exact(&mut len).unwrap();
        let mut rest = vec![0u8; u32::from_le_bytes(len) as usize - 4];
        s.read_exact(&mut rest).unwrap();
        drop(s);
    });
    // 64 spp at 256 x 256: 7 passes of ~1 MB each, so writes fail after the close.
    let err = render_to(&addr, &png, &["-D", "res=256", "--spp", "64"]);
    server.join().unwrap();
    assert_eq!(err.matches("--display-server").count(), 1, "{err}");
    assert!(err.contains("lost the connection"), "{err}");
    assert!(png.is_file());
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn no_server_is_reported_once_and_the_render_goes_on() {
    let d = common::tmpdir("tev", "none");
    let png = d.join("box.png");
    // A port nobody listens on: bound, then closed.
    let addr = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().to_string();
    let err = render_to(&addr, &png, &["-D", "res=32", "--spp", "4"]);
    assert_eq!(err.matches("--display-server").count(), 1, "{err}");
    assert!(err.contains("cannot connect"), "{err}");
    assert!(png.is_file());
    // A malformed address is an argument error.
    let o = common::bin()
        .arg("render")
        .arg(common::cornell())
        .args(["-o", "x.png", "--display-server", "localhost"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("HOST:PORT"));
    std::fs::remove_dir_all(&d).ok();
}
