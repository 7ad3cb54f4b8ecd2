fn main() {
    let p = std::env::args().nth(1).unwrap();
    match gearbox::load(std::path::Path::new(&p)) {
        Ok(g) => println!("{g:#?}"),
        Err(e) => println!("REFUSED: {e}"),
    }
}
