//! Prints the mean linear RGB of each EXR given on the command line (used
//! for the "left out" check in docs/results.md).

fn main() {
    for arg in std::env::args().skip(1) {
        match gibake_image::Image::read_exr(std::path::Path::new(&arg)) {
            Ok(img) => {
                let m = img.mean();
                println!("{arg}: mean {:.6e} {:.6e} {:.6e}", m.x, m.y, m.z);
            }
            Err(e) => println!("{arg}: {e}"),
        }
    }
}
