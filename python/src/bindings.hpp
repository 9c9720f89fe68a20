#pragma once
// The parts of the imufusion module, one function per file of python/src.

#include <pybind11/pybind11.h>

namespace imufusion {
class Reconstructor;
}

namespace imufusion::python {

void bind_types(pybind11::module_& m);     // types.cpp: enums, Intrinsics, ImuSample
void bind_config(pybind11::module_& m);    // config.cpp: ReconstructorConfig and the presets
void bind_scanner(pybind11::module_& m);   // scanner.cpp: Reconstructor, FrameResult, raycasts
void bind_sequence(pybind11::module_& m);  // sequence.cpp: SequenceReader, SequenceWriter
void bind_mesh_io(pybind11::module_& m);   // mesh_io.cpp: Mesh, trajectories, synthesize
// mesh_changes.cpp: Reconstructor.extract_mesh_changes, the incremental mesh
void bind_mesh_changes(pybind11::class_<Reconstructor>& c);

}  // namespace imufusion::python
