// The plant's broker messages: topic tree and payloads (docs/plant.md). Filled in next.
#pragma once
