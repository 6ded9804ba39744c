// The models take directions in the local frame of a surface point (core/local_dir.h).
#pragma once
#include "core/local_dir.h"
