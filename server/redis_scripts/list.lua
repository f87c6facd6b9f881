-- A page of a tenant's records (ListCall in redis_scripts.h).
-- KEYS: [1] tenant ids. ARGV: [1] after ('' = from the start), [2] limit,
-- [3] hash prefix.
-- Returns up to limit + 1 entries {id, info, gen, pttl, inc}; expired ids
-- are dropped.
local out = {}
local start = ARGV[1] == '' and '-' or ('(' .. ARGV[1])
local want = tonumber(ARGV[2]) + 1
while #out < want do
  local ids = redis.call('ZRANGEBYLEX', KEYS[1], start, '+', 'LIMIT', 0, want)
  if #ids == 0 then break end
  for _, id in ipairs(ids) do
    local k = ARGV[3] .. id
    local v = redis.call('HMGET', k, 'info', 'gen', 'inc')
    if v[1] then
      if #out < want then
        out[#out + 1] = {id, v[1], v[2], redis.call('PTTL', k), v[3] or ''}
      end
    else
      redis.call('ZREM', KEYS[1], id)
    end
    start = '(' .. id
  end
end
return out
