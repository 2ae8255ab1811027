#pragma once
// preCICE v3's C++ API, served by cosim's coupler: include this one header.

#include "precice/Exceptions.hpp"
#include "precice/Participant.hpp"
#include "precice/Tooling.hpp"
#include "precice/Types.hpp"
#include "precice/Version.h"
#include "precice/export.h"
#include "precice/span.hpp"
