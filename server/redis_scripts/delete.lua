-- Deletes a record (DeleteCall in redis_scripts.h).
-- KEYS: [1] session hash, [2] tenant ids, [3] all sessions. ARGV: [1] id.
-- Returns the deleted count.
local n = redis.call('DEL', KEYS[1])
redis.call('ZREM', KEYS[2], ARGV[1])
redis.call('ZREM', KEYS[3], KEYS[1])
return n
