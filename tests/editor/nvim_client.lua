-- A headless Neovim as a language client of `rmv lsp` (tests/test_lsp_neovim.py):
-- opens a spec, waits for its diagnostics, asks for hover, completion and a
-- definition, applies a formatting edit, and writes what it saw as JSON.
--   nvim --headless --clean -u NONE -l? (0.7: -c "luafile nvim_client.lua")
-- The environment names the server's command (RMV_LSP_COMMAND, JSON), the file to
-- open (RMV_FILE), the positions to ask at (RMV_HOVER, RMV_COMPLETE: "line,col",
-- 0-based) and the output (RMV_OUT).

local out = {}
local function finish(code)
  local file = io.open(os.getenv("RMV_OUT"), "w")
  file:write(vim.fn.json_encode(out))
  file:close()
  vim.cmd(code == 0 and "qall!" or "cquit! " .. code)
end

local function position(name)
  local line, col = os.getenv(name):match("(%d+),(%d+)")
  return { line = tonumber(line), character = tonumber(col) }
end

local ok, err = pcall(function()
  vim.cmd("edit " .. vim.fn.fnameescape(os.getenv("RMV_FILE")))
  local buf = vim.api.nvim_get_current_buf()
  vim.bo[buf].filetype = "rmv"
  local client_id = vim.lsp.start_client({
    name = "rmv",
    cmd = vim.fn.json_decode(os.getenv("RMV_LSP_COMMAND")),
    root_dir = vim.fn.getcwd(),
  })
  assert(client_id, "the server did not start")
  vim.lsp.buf_attach_client(buf, client_id)

  -- diagnostics: wait until the server has published some for this buffer
  local got = vim.wait(120000, function() return #vim.diagnostic.get(buf) > 0 end, 100)
  assert(got, "no diagnostics arrived")
  out.diagnostics = {}
  for _, d in ipairs(vim.diagnostic.get(buf)) do
    table.insert(out.diagnostics, { code = d.code, lnum = d.lnum, col = d.col, message = d.message })
  end

  local uri = vim.uri_from_bufnr(buf)
  local function ask(method, at, extra)
    local params = { textDocument = { uri = uri }, position = at }
    for k, v in pairs(extra or {}) do params[k] = v end
    local answers = vim.lsp.buf_request_sync(buf, method, params, 60000)
    assert(answers and answers[client_id], method .. ": no answer")
    assert(not answers[client_id].err, method .. ": " .. vim.inspect(answers[client_id].err))
    return answers[client_id].result
  end

  local hover = ask("textDocument/hover", position("RMV_HOVER"))
  out.hover = hover and hover.contents and hover.contents.value or vim.NIL
  local definition = ask("textDocument/definition", position("RMV_HOVER"))
  out.definition = definition
  local completion = ask("textDocument/completion", position("RMV_COMPLETE"))
  out.completion = {}
  for _, item in ipairs(completion.items or completion) do
    table.insert(out.completion, item.label)
  end

  -- formatting: the server's edit applied to the buffer, as :lua vim.lsp.buf.formatting_sync() does
  vim.lsp.buf.formatting_sync(nil, 60000)
  out.formatted = table.concat(vim.api.nvim_buf_get_lines(buf, 0, -1, false), "\n") .. "\n"
  vim.lsp.stop_client(client_id)
end)
if not ok then
  out.error = tostring(err)
  finish(3)
else
  finish(0)
end
