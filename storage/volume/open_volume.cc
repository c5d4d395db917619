// OpenVolume (volume.h): the reader a file's extension names.
#include "storage/volume/volume.h"

#include <string_view>

#include "storage/volume/text_internal.h"

namespace simplexdb {

Result<VolumeInfo> OpenVolume(const std::string& path) {
  const std::string lower = volume_internal::Lower(path);
  const auto ends_with = [&](std::string_view suffix) {
    return lower.size() >= suffix.size() &&
           lower.compare(lower.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  if (ends_with(".nrrd") || ends_with(".nhdr")) return OpenNrrd(path);
  if (ends_with(".nii")) return OpenNifti(path);
  if (ends_with(".nii.gz")) {
    return Status::NotSupported(path + ": gzip-compressed NIfTI is not read; "
                                "gunzip it to a .nii first");
  }
  if (ends_with(".hdr") || ends_with(".img")) {
    return Status::NotSupported(path + ": NIfTI-1/Analyze .hdr/.img pairs are not "
                                "read; convert to a single-file .nii");
  }
  return Status::InvalidArgument(path + ": not a .nrrd, .nhdr or .nii file; raw "
                                 "input needs --dims and --type (and --endian, "
                                 "--offset if not little-endian at byte 0)");
}

}  // namespace simplexdb
