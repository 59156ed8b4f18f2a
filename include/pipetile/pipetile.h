// pipetile — the whole public API in one include.
#pragma once

#include <pipetile/caps.h>
#include <pipetile/contour.h>
#include <pipetile/error.h>
#include <pipetile/gltf.h>
#include <pipetile/graph.h>
#include <pipetile/mesh.h>
#include <pipetile/mesh_io.h>
#include <pipetile/multires.h>
#include <pipetile/output_set.h>
#include <pipetile/quality.h>
#include <pipetile/slicer.h>
#include <pipetile/tiler.h>
#include <pipetile/validate.h>
#include <pipetile/volume.h>
