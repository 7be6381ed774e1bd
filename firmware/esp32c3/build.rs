//! Link script for the ESP32-C3 image: esp-hal's `linkall.x` pulls in memory layout,
//! ROM symbols and the runtime (DESIGN.md §5).
fn main() {
    println!("cargo:rustc-link-arg=-Tlinkall.x");
    println!("cargo:rerun-if-changed=build.rs");
}
