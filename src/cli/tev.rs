//! `--display HOST:PORT`: the image in progress, streamed to the tev viewer over its TCP
//! protocol (as pbrt-v4's `--display-server` does). A thread of its own connects and
//! sends, so a slow or absent viewer never holds the render up; a viewer that cannot be
//! reached, or goes away, costs one warning and the render goes on.
//!
//! The protocol (tev's `Ipc.h`): each packet is its length as a little-endian `u32`
//! (the length field included), a type byte, then the fields, integers little-endian
//! and strings NUL-terminated. ember sends `CreateImage` (type 4: grab focus, name,
//! width, height, channel count, channel names) once, then `UpdateImage` (type 6, its
//! third version: grab focus, name, channel count, channel names, x, y, width, height,
//! an `i64` offset and stride per channel, then the tile's `f32` values) per tile.

use std::io::Write;
use std::net::{TcpStream, ToSocketAddrs};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::thread::JoinHandle;
use std::time::Duration;

use ember::image::Image;

/// Where the viewer listens: `--display HOST:PORT` (tev's default port is 14158).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DisplayAddress {
    pub host: String,
    pub port: u16,
}

impl std::fmt::Display for DisplayAddress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.host, self.port)
    }
}

/// `HOST:PORT`, `[IPv6]:PORT`.
pub fn parse_address(s: &str) -> Result<DisplayAddress, String> {
    let bad = || format!("expected HOST:PORT (e.g. localhost:14158, tev's default), got {s:?}");
    let (host, port) = s.trim().rsplit_once(':').ok_or_else(bad)?;
    let host = host.trim_start_matches('[').trim_end_matches(']');
    let port: u16 = port.parse().map_err(|_| bad())?;
    if host.is_empty() || port == 0 {
        return Err(bad());
    }
    Ok(DisplayAddress {
        host: host.to_owned(),
        port,
    })
}

/// How long connecting, and one write, may take before the viewer counts as gone.
const TIMEOUT: Duration = Duration::from_secs(3);
/// Side of the tiles an image is sent in (tev's own Python client sends 128×128).
const TILE: u32 = 128;
const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// The connection to a viewer, run by its own thread.
pub struct Display {
    images: Option<SyncSender<Image>>,
    thread: Option<JoinHandle<()>>,
}

impl Display {
    /// Starts connecting to the viewer at `address`, to show a `width × height` image
    /// called `name`.
    pub fn start(address: DisplayAddress, name: String, width: u32, height: u32) -> Display {
        // One image waits at most: a newer one is dropped while the viewer is busy.
        let (images, receive) = mpsc::sync_channel(1);
        let thread = std::thread::spawn(move || {
            let viewer = Viewer {
                address,
                name,
                width,
                height,
            };
            if let Err(e) = viewer.run(receive) {
                eprintln!("warning: {e}: the render goes on without the live preview");
            }
        });
        Display {
            images: Some(images),
            thread: Some(thread),
        }
    }

    /// Sends `image` if the viewer is ready for one; otherwise it is skipped.
    pub fn show(&self, image: Image) {
        if let Some(images) = &self.images {
            match images.try_send(image) {
                Ok(()) | Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => {}
            }
        }
    }

    /// Sends the final `image` and waits until it is sent, or the viewer is gone.
    pub fn finish(mut self, image: Image) {
        if let Some(images) = self.images.take() {
            // An error means the thread has ended (the viewer is gone, and said so).
            let _ = images.send(image);
        }
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl Drop for Display {
    fn drop(&mut self) {
        // Without `finish` (an error path): the thread ends when the channel closes;
        // it is not waited for.
        self.images.take();
    }
}

/// The sending side, on the display thread.
struct Viewer {
    address: DisplayAddress,
    name: String,
    width: u32,
    height: u32,
}

impl Viewer {
    fn run(&self, images: Receiver<Image>) -> Result<(), String> {
        let mut stream = self.connect()?;
        let gone =
            |e: std::io::Error| format!("the tev viewer at {} went away ({e})", self.address);
        stream
            .write_all(&create_image(&self.name, self.width, self.height))
            .map_err(gone)?;
        for image in images {
            for packet in update_image(&self.name, &image) {
                stream.write_all(&packet).map_err(gone)?;
            }
        }
        Ok(())
    }

    fn connect(&self) -> Result<TcpStream, String> {
        let unreachable =
            |why: String| format!("cannot reach the tev viewer at {} ({why})", self.address);
        let addresses = (self.address.host.as_str(), self.address.port)
            .to_socket_addrs()
            .map_err(|e| unreachable(e.to_string()))?;
        let mut last = String::from("the host has no address");
        for address in addresses {
            match TcpStream::connect_timeout(&address, TIMEOUT) {
                Ok(stream) => {
                    stream
                        .set_write_timeout(Some(TIMEOUT))
                        .map_err(|e| unreachable(e.to_string()))?;
                    let _ = stream.set_nodelay(true);
                    return Ok(stream);
                }
                Err(e) => last = e.to_string(),
            }
        }
        Err(unreachable(last))
    }
}

/// A packet: its length first (itself included), then `body`.
fn packet(body: Vec<u8>) -> Vec<u8> {
    let len = u32::try_from(body.len() + 4).expect("tiles keep packets small");
    let mut out = Vec::with_capacity(body.len() + 4);
    out.extend_from_slice(&len.to_le_bytes());
    out.extend(body);
    out
}

fn push_str(out: &mut Vec<u8>, s: &str) {
    // A NUL inside would end the string early: tev reads up to the first.
    out.extend(s.bytes().filter(|&b| b != 0));
    out.push(0);
}

fn push_i32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&i32::try_from(v).unwrap_or(i32::MAX).to_le_bytes());
}

/// `CreateImage`: a black `width × height` image of channels R, G, B, in focus.
fn create_image(name: &str, width: u32, height: u32) -> Vec<u8> {
    let mut body = vec![4u8, 1];
    push_str(&mut body, name);
    push_i32(&mut body, width);
    push_i32(&mut body, height);
    push_i32(&mut body, CHANNELS.len() as u32);
    for channel in CHANNELS {
        push_str(&mut body, channel);
    }
    packet(body)
}

/// `UpdateImage` packets of `image`, one per tile, its pixels interleaved RGB.
fn update_image(name: &str, image: &Image) -> Vec<Vec<u8>> {
    let mut packets = Vec::new();
    for y0 in (0..image.height).step_by(TILE as usize) {
        for x0 in (0..image.width).step_by(TILE as usize) {
            let (w, h) = (TILE.min(image.width - x0), TILE.min(image.height - y0));
            let mut body = vec![6u8, 0];
            push_str(&mut body, name);
            push_i32(&mut body, CHANNELS.len() as u32);
            for channel in CHANNELS {
                push_str(&mut body, channel);
            }
            for v in [x0, y0, w, h] {
                push_i32(&mut body, v);
            }
            for offset in 0..CHANNELS.len() as i64 {
                body.extend_from_slice(&offset.to_le_bytes());
            }
            for _ in CHANNELS {
                body.extend_from_slice(&(CHANNELS.len() as i64).to_le_bytes());
            }
            body.reserve((w * h * 3 * 4) as usize);
            for y in y0..y0 + h {
                let row = (y * image.width) as usize;
                for p in &image.pixels[row + x0 as usize..row + (x0 + w) as usize] {
                    for v in [p.x, p.y, p.z] {
                        body.extend_from_slice(&v.to_le_bytes());
                    }
                }
            }
            packets.push(packet(body));
        }
    }
    packets
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_parse_or_say_what_is_expected() {
        let a = parse_address("localhost:14158").unwrap();
        assert_eq!((a.host.as_str(), a.port), ("localhost", 14158));
        let a = parse_address("[::1]:9000").unwrap();
        assert_eq!((a.host.as_str(), a.port), ("::1", 9000));
        for bad in [
            "localhost",
            ":14158",
            "host:port",
            "host:70000",
            "host:0",
            "",
        ] {
            let e = parse_address(bad).unwrap_err();
            assert!(e.contains("HOST:PORT"), "{bad}: {e}");
        }
    }

    #[test]
    fn an_image_is_sent_in_tiles_that_cover_it_once() {
        let (w, h) = (300u32, 130u32);
        let image = Image {
            width: w,
            height: h,
            pixels: vec![glam::Vec3::ONE; (w * h) as usize],
        };
        let packets = update_image("x", &image);
        // 3 tiles across, 2 down.
        assert_eq!(packets.len(), 6);
        let values: usize = packets
            .iter()
            .map(|p| p.len() - 4 - 2 - 2 - 4 - 6 - 16 - 48)
            .sum();
        assert_eq!(values, (w * h * 3 * 4) as usize);
        for p in &packets {
            assert_eq!(
                u32::from_le_bytes(p[..4].try_into().unwrap()) as usize,
                p.len()
            );
        }
    }
}
