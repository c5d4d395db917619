// The Python interpreter that can run VTK, for tests that read the files we
// write with VTK itself.
#pragma once

#include <cstdlib>
#include <string>

namespace simplexdb::testing {

// The first interpreter that can import `module` (e.g. "vtkmodules.vtkIOXML"),
// or "" when none can. Debian's python3-vtk9 is installed for
// /usr/bin/python3, which a python3 earlier on PATH (pyenv, a virtualenv)
// may not see.
inline std::string FindPythonWithVtk(const std::string& module) {
  for (const char* python : {"/usr/bin/python3", "python3"}) {
    const std::string cmd = std::string(python) + " -c 'import " + module + "' >/dev/null 2>&1";
    if (std::system(cmd.c_str()) == 0) return python;
  }
  return "";
}

}  // namespace simplexdb::testing
