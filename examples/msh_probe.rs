fn main() {
    for a in std::env::args().skip(1) {
        match blossomquad::msh::read_file(std::path::Path::new(&a)) {
            Ok(m) => {
                println!(
                    "{a}: OK {} nodes {} elements; warnings {:?}",
                    m.node_count(),
                    m.element_count(),
                    m.warnings
                );
                print!("{}", blossomquad::msh::summary(&m));
            }
            Err(e) => println!("ERR {e}"),
        }
    }
}
