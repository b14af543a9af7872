// Moved to core/interrupt.h, where encode/ and metrics/ reach it too.
#pragma once

#include "core/interrupt.h"
