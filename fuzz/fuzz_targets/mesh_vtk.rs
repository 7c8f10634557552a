//! VTK meshes: `endoloc_data::mesh::parse_vtk`, then what `read_mesh` does with a mesh.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("colon.vtk");
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let parsed = endoloc_data::mesh::parse_vtk(path, text);
    if let Ok(mesh) = parsed
        && mesh.validate().is_ok()
    {
        let _ = mesh.bounding_box();
        let _ = mesh.surface_area();
        let _ = mesh.boundary_edge_count();
    }
});
