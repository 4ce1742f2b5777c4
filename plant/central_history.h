// The plant's central history in PostgreSQL (docs/plant.md). Filled in next.
#pragma once
