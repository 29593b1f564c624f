// Internal to io/: small helpers shared by the archive writer (archive.cc)
// and reader (archive_reader.cc). Not part of the library's interface.
#pragma once

#include <hdf5.h>

namespace rodmesh::h5 {

// RAII holder for an HDF5 identifier and the function that closes it.
struct Hid {
  hid_t id = -1;
  herr_t (*close)(hid_t) = nullptr;
  Hid(hid_t i, herr_t (*c)(hid_t)) : id(i), close(c) {}
  Hid(const Hid&) = delete;
  Hid& operator=(const Hid&) = delete;
  ~Hid() {
    if (id >= 0 && close) close(id);
  }
  operator hid_t() const { return id; }
};

// A new variable-length UTF-8 string type (close with H5Tclose).
inline hid_t stringType() {
  hid_t t = H5Tcopy(H5T_C_S1);
  H5Tset_size(t, H5T_VARIABLE);
  H5Tset_cset(t, H5T_CSET_UTF8);
  return t;
}

// The name given to HDF5 for files in memory (core driver without backing
// store). The core driver refuses a file image whose name exists on disk;
// nothing can exist below /dev/null.
constexpr const char* kMemoryFileName = "/dev/null/rodmesh-archive-in-memory";

}  // namespace rodmesh::h5
